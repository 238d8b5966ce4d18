"""Local optimisers of the identification's fit (5.25) in a registry: each takes the fit in
scaled coordinates (:class:`ScaledProblem`), a start and a box, and returns scipy's result.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
from scipy.optimize import OptimizeResult, least_squares, minimize

__all__ = ["ScaledProblem", "OPTIMISERS"]


@dataclass(frozen=True)
class ScaledProblem:
    """The fit (5.25) as a local optimiser of :data:`OPTIMISERS` sees it: coordinates
    z = theta / scale (shape (n_theta,)), cost J(theta) / J0 with J0 the start's cost.

    Attributes
    ----------
    cost : callable
        z -> (J / J0, dJ/dz / J0); the penalty and a zero gradient where the model is not physical.
    residuals : callable
        z -> (r / sqrt(J0), dr/dz / sqrt(J0)) with r = sqrt(w) [mean error, std error] of shape
        (n_residuals,) and its Jacobian (n_residuals, n_theta), or None where not physical.
    n_residuals : int
    penalty : float
        The cost that stands for "not physical" (rejects a step).
    max_iter : int
        Iteration (or evaluation) limit of one local fit.
    scale : ndarray, shape (n_theta,)
        theta = z * scale.
    """

    cost: Callable
    residuals: Callable
    n_residuals: int
    penalty: float
    max_iter: int
    scale: np.ndarray


def _lbfgsb(problem: ScaledProblem, z0, box) -> OptimizeResult:
    """Quasi-Newton (L-BFGS-B) on the scaled cost with the model's analytic gradient."""
    return minimize(problem.cost, z0, jac=True, method="L-BFGS-B", bounds=box, options={"maxiter": problem.max_iter, "ftol": 1e-15, "gtol": 1e-10})


def _gauss_newton(problem: ScaledProblem, z0, box) -> OptimizeResult:
    """Trust-region Gauss-Newton (scipy ``least_squares``, "trf", bounds) on the residuals of
    (5.25), r = sqrt(w) [mean error, std error], with the Jacobian from the model's forward
    sensitivities. (5.25) is a sum of squares, so J'J is a Hessian model for free: about a
    third of the iterations of L-BFGS-B, each costing one sensitivity solve."""
    lo, hi = np.array(box, float).T
    n = problem.n_residuals
    cache = {}

    def residuals(z):
        out = problem.residuals(z)
        if out is None:
            cache.clear()  # non-physical: a cost far above the start makes the step be rejected
            return np.full(n, np.sqrt(problem.penalty / n))
        res, jac = out
        cache.update(z=z.copy(), jac=jac)
        return res

    def jacobian(z):
        if "z" not in cache or not np.array_equal(cache["z"], z):
            residuals(z)
        return cache["jac"]

    out = least_squares(residuals, np.clip(z0, lo, hi), jac=jacobian, bounds=(lo, hi), method="trf", ftol=1e-12, xtol=1e-12, gtol=1e-12,
                        max_nfev=problem.max_iter)
    return OptimizeResult(x=out.x, fun=2.0 * out.cost, nit=out.njev, nfev=out.nfev, success=out.status > 0, message=out.message)


#: Registry of local optimisers of the fit; config strings select them.
OPTIMISERS: dict[str, Callable] = {"lbfgsb": _lbfgsb, "gauss_newton": _gauss_newton}

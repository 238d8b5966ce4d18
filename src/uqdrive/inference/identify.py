"""Identification of the parameter distributions from measured mean and std trajectories
(thesis sec. 5.3): weighted cost (5.25) with the STD/INP/DST weights (5.26), (5.28) in a
registry, quasi-Newton fits with analytic gradients, physical guards, multi-start, error bars.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Callable, Protocol

import numpy as np

from ..numerics.threads import single_blas_thread
from ..settings import ParameterLayout
from .optimisers import OPTIMISERS, ScaledProblem
from .sampling import gauss_newton_errors, run_influence, sampling_errors

__all__ = ["MomentModel", "WeightContext", "COSTS", "cost_weights", "STATE_SCALES", "state_weights", "OPTIMISERS", "ScaledProblem", "initial_guess", "default_bounds", "DistributionEstimator"]


class MomentModel(Protocol):
    """What the estimator needs of a model: parameter names and moments with gradients.

    A model may also offer ``moments_vjp(theta) -> (moments, vjp)`` with
    ``vjp(dJ_dmean, dJ_dvariance) -> dJ/dtheta``; the estimator then uses it for the gradient.
    """

    theta_names: tuple

    def moments(self, theta, gradient: bool = False):
        """Mean and variance of the states, shape (4, T) each in the states' units, at the
        distribution parameters ``theta`` (shape (n_theta,), ``theta_names`` order); with
        ``gradient`` also their derivatives, shape (n_theta, 4, T)."""


@dataclass(frozen=True)
class WeightContext:
    """Data the weight schemes may use: steering on the grid (rad, (T,)) and D_KL (4, T)."""

    delta: np.ndarray
    kl_divergence: np.ndarray | None = None


def _std(ctx: WeightContext, shape):
    """STD weights [1 1 1 1] at every sample."""
    return np.ones(shape)


def _inp(ctx: WeightContext, shape):
    """INP weights (5.26): exp(-|u(t_k)|) for every state."""
    return np.broadcast_to(np.exp(-np.abs(ctx.delta)), shape).copy()


def _dst(ctx: WeightContext, shape):
    """DST weights (5.28): exp(-|D_KL|) of the LST and NLST outputs (corrected (5.27));
    where D_KL is undefined (t = 0, zero variance) the weight is one."""
    if ctx.kl_divergence is None:
        raise ValueError("the DST cost needs the KL divergence between the LST and NLST outputs")
    return np.where(np.isfinite(ctx.kl_divergence), np.exp(-np.abs(ctx.kl_divergence)), 1.0)


#: Registry of weight schemes of the cost (5.25); config strings select them.
COSTS: dict[str, Callable] = {"std": _std, "inp": _inp, "dst": _dst}


def cost_weights(name: str, ctx: WeightContext, shape) -> np.ndarray:
    """Weights of the cost (5.25) by the registered scheme ``name`` (STD, INP, DST: ``COSTS``), broadcast
    to ``shape`` (n_states, T); an unknown name raises ValueError listing the known ones."""
    try:
        scheme = COSTS[name.lower()]
    except KeyError:
        raise ValueError(f"unknown cost '{name}'; choose one of {', '.join(COSTS)}") from None
    return scheme(ctx, shape)


def _no_scale(mean, std):
    """Residuals in SI units, as the thesis prints (5.25): y (metres) dominates the cost."""
    return np.ones(mean.shape[0])


def _rms_mean(mean, std):
    """Each state's residuals divided by the RMS of its measured mean trajectory."""
    return np.sqrt(np.mean(mean**2, axis=1))


def _rms_std(mean, std):
    """Each state's residuals divided by the RMS of its measured standard deviation."""
    return np.sqrt(np.mean(std**2, axis=1))


#: Registry of per-state scales of the residuals of (5.25); config strings select them. Any
#: scale other than "none" makes the cost independent of the states' units.
STATE_SCALES: dict[str, Callable] = {"none": _no_scale, "rms_mean": _rms_mean, "rms_std": _rms_std}


def state_weights(name: str, measured_mean, measured_std) -> np.ndarray:
    """Per-state factors 1 / scale_i^2 (shape (n_states,)) that multiply the weights of (5.25).

    Parameters
    ----------
    name : str
        Key of :data:`STATE_SCALES`.
    measured_mean, measured_std : ndarray, shape (n_states, T)
    """
    try:
        scale = STATE_SCALES[name.lower()](np.asarray(measured_mean, float), np.asarray(measured_std, float))
    except KeyError:
        raise ValueError(f"unknown state scale '{name}'; choose one of {', '.join(STATE_SCALES)}") from None
    if not np.all(np.isfinite(scale) & (scale > 0)):
        raise ValueError(f"state scale '{name}' is zero or not finite for a state ({scale.tolist()}); use state_scale 'none'")
    return 1.0 / scale**2


def initial_guess(theta, e_min: float, e_max: float, rng: np.random.Generator):
    """Random initial guesses deviating from ``theta`` by between e_min and e_max, thesis (5.34)."""
    theta = np.asarray(theta, float)
    e = rng.uniform(e_min, e_max, theta.shape)
    sign = rng.choice([-1.0, 1.0], theta.shape)
    return theta * (1.0 + sign * e)


def default_bounds(theta_names, wheelbase: float):
    """Physical boxes: mu > 0, 0 < l_f < L, std > 0, mean wind within +- 5 kN
    (:meth:`uqdrive.settings.ParameterLayout.identify_box`)."""
    return ParameterLayout.identify_box(theta_names, wheelbase)


class DistributionEstimator:
    """Fit distribution parameters so that model moments match measured mean and std, (5.25).

    Parameters
    ----------
    model : MomentModel
        E.g. :class:`uqdrive.vehicle.chaos.LSTChaosModel`; may be any model with the protocol.
    cost : {"std", "inp", "dst"}
        Weight scheme, see :data:`COSTS`.
    bounds : sequence of (low, high), optional
        Box on each parameter (default: :func:`default_bounds` needs ``wheelbase``).
    starts : int
        Extra starting points of a global stage: Sobol-like random points in the box are ranked
        by cost and the best ``starts`` are polished too (0: the thesis' single local fit).
    rng : numpy.random.Generator, optional
        Source of the global-stage points.
    max_iter : int
        L-BFGS-B iteration limit per start.
    state_scale : {"none", "rms_mean", "rms_std"}
        Per-state scale of the residuals, see :data:`STATE_SCALES` ("none": the thesis' SI units).
    optimiser : {"lbfgsb", "gauss_newton"}
        Local optimiser, see :data:`OPTIMISERS`: quasi-Newton with the adjoint gradient (the
        thesis' method class) or trust-region Gauss-Newton with forward sensitivities.
    noise_variance : ndarray, shape (n_states,), optional
        Variance of white measurement noise in the data, added to the model's variance before
        its std is compared with the measured one (default: none).

    Attributes
    ----------
    theta_ : ndarray, shape (n_theta,)
        Estimate in ``model.theta_names`` order, in the parameters' units; standard deviations reported as |sigma|.
    cost_, n_iter_, n_eval_, converged_, message_ : fit diagnostics
    theta_std_ : ndarray, shape (n_theta,)
        Standard errors: sandwich (sampling error of the statistics) when :meth:`fit` is given the
        realisations (NaN for a std at zero), else Gauss-Newton (see :meth:`_fit`).
    gauss_newton_std_ : ndarray, shape (n_theta,)
        The Gauss-Newton standard errors s^2 (J'J)^-1 (residuals taken as independent).
    upper_bounds_, misfit_reference_ : dict, MisfitReference or None
        With the realisations: one-sided 95 % upper bound of each std at zero (by name), and the
        cost's distribution at the optimum if the model is right.
    start_results_ : list of (theta, cost, success)
        Each start's local optimum (the first is the given start's), theta with |sigma|.
    problem_ : ScaledProblem
        The scaled fit the optimisers were given.
    """

    def __init__(self, model: MomentModel, cost: str = "std", bounds=None, starts: int = 0, rng=None, max_iter: int = 300, wheelbase: float | None = None,
                 state_scale: str = "none", optimiser: str = "lbfgsb", noise_variance=None):
        if cost.lower() not in COSTS:
            raise ValueError(f"unknown cost '{cost}'; choose one of {', '.join(COSTS)}")
        if state_scale.lower() not in STATE_SCALES:
            raise ValueError(f"unknown state scale '{state_scale}'; choose one of {', '.join(STATE_SCALES)}")
        if optimiser.lower() not in OPTIMISERS:
            raise ValueError(f"unknown optimiser '{optimiser}'; choose one of {', '.join(OPTIMISERS)}")
        self.state_scale = state_scale.lower()
        self.optimiser = optimiser.lower()
        self.model = model
        self.cost = cost.lower()
        self.bounds = bounds if bounds is not None else default_bounds(model.theta_names, wheelbase if wheelbase is not None else 2.85)
        self.starts = int(starts)
        self.rng = rng if rng is not None else np.random.default_rng(0)
        self.max_iter = int(max_iter)
        self.noise_variance = noise_variance
        self._nv = 0.0 if noise_variance is None else np.asarray(noise_variance, float)[:, None]

    # -- objective --------------------------------------------------------------------------
    def _objective(self, theta, gradient=True):
        # Models with ``moments_vjp`` give the gradient by one adjoint pass (cost independent of
        # the number of parameters); others by their forward sensitivities.
        adjoint = gradient and hasattr(self.model, "moments_vjp")
        try:
            if adjoint:
                r, vjp = self.model.moments_vjp(theta)
            else:
                r = self.model.moments(theta, gradient=gradient)
        except (ValueError, np.linalg.LinAlgError):
            return None
        std = np.sqrt(np.maximum(r.variance + self._nv, 1e-300))
        em, es = r.mean - self._mean, std - self._std
        if not (np.all(np.isfinite(em)) and np.all(np.isfinite(es))):
            return None
        J = float(np.sum(self._w * (em**2 + es**2)))
        if not gradient:
            return J, None, r
        if adjoint:
            return J, vjp(2.0 * self._w * em, self._w * es / std), r
        dstd = r.variance_gradient / (2.0 * std)
        g = 2.0 * np.sum(self._w * (em * r.mean_gradient + es * dstd), axis=(1, 2))
        return J, g, r

    def cost_function(self, theta) -> float:
        """The weighted cost (5.25) at ``theta`` after :meth:`fit` set the data (inf if not physical)."""
        out = self._objective(np.asarray(theta, float), gradient=False)
        return float("inf") if out is None else out[0]

    def _scaled(self, z):
        theta = z * self._scale
        out = self._objective(theta)
        if out is None:  # non-physical or diverging model: push the line search back
            return self._penalty, np.zeros_like(z)
        J, g, _ = out
        return J / self._J0, g * self._scale / self._J0

    def _scaled_residuals(self, z):
        try:  # the sensitivities come with the moments; the Jacobian reads them back
            res, jac = self._weighted_residuals(self.model.moments(z * self._scale, gradient=True), jacobian=True)
        except (ValueError, np.linalg.LinAlgError):
            return None
        if not (np.all(np.isfinite(res)) and np.all(np.isfinite(jac))):
            return None
        root_J0 = np.sqrt(self._J0)
        return res / root_J0, jac * (self._scale / root_J0)

    def fit(self, measured_mean, measured_std, theta0, context: WeightContext | None = None, runs=None) -> "DistributionEstimator":
        """Fit from ``theta0``; measured arrays have shape (4, T) on the model's time grid.

        ``runs`` (n_states, n, T), optional: the realisations behind the statistics, for sandwich
        standard errors and the misfit's reference (goodness of fit). The model's matrices are
        small, where BLAS threads only add overhead, so the fit runs with one BLAS thread.
        """
        with single_blas_thread():
            self._fit(measured_mean, measured_std, theta0, context)
            if runs is not None:
                self._sampling_errors(np.asarray(runs, float))
            return self

    def _fit(self, measured_mean, measured_std, theta0, context: WeightContext | None = None) -> "DistributionEstimator":
        """Fit from ``theta0``; measured arrays have shape (4, T) on the model's time grid.

        Error bars: with residuals r (weighted mean and std errors) and their Jacobian J at the
        estimate, cov = s^2 (J'J)^-1 with s^2 = sum r^2 / (n - p). Consecutive residuals are
        strongly correlated, so these are lower bounds; the emcee posterior is the honest check.
        """
        self._mean = np.asarray(measured_mean, float)
        self._std = np.asarray(measured_std, float)
        if self._mean.shape != self._std.shape or self._mean.ndim != 2:
            raise ValueError("measured mean and std must both have shape (n_states, n_time)")
        ctx = context if context is not None else WeightContext(np.zeros(self._mean.shape[1]))
        self._w = cost_weights(self.cost, ctx, self._mean.shape) * state_weights(self.state_scale, self._mean, self._std)[:, None]
        theta0 = np.asarray(theta0, float)
        first = self._objective(theta0, gradient=False)
        if first is None:
            raise ValueError(f"initial guess {theta0.tolist()} is not physical (model could not be evaluated)")
        self._J0 = max(first[0], 1e-300)
        self._penalty = 1e6
        self._scale = np.where(np.abs(theta0) > 1e-8, np.abs(theta0), 1.0)
        starts = [theta0] + self._global_candidates()
        best, n_iter, n_eval = None, 0, 0
        self.start_results_ = []
        lo, hi = np.array(self.bounds, float).T
        box = list(zip(lo / self._scale, hi / self._scale))

        self.problem_ = ScaledProblem(self._scaled, self._scaled_residuals, 2 * self._mean.size, self._penalty, self.max_iter, self._scale)

        def local(z0):
            return OPTIMISERS[self.optimiser](self.problem_, z0, box)

        for start in starts:
            res = local(np.clip(start, lo, hi) / self._scale)
            n_iter += res.nit
            n_eval += res.nfev
            self.start_results_.append((self._absolute_std(res.x * self._scale), float(res.fun * self._J0), bool(res.success)))
            if best is None or res.fun < best.fun:
                best = res
        success, message = bool(best.success), str(best.message)
        if not success and best.fun < self._penalty:
            # L-BFGS-B also stops "ABNORMAL" when the line search cannot improve at machine
            # precision. A restart from that point settles it: a true optimum stays put.
            again = local(best.x)
            n_iter, n_eval = n_iter + again.nit, n_eval + again.nfev
            if again.success and again.fun <= best.fun:
                success, message = True, f"{again.message} (after a restart from an abnormal stop)"
            elif abs(again.fun - best.fun) <= 1e-9 * abs(best.fun):
                success = True
                message = f"{message}; a restart from there changed the cost by < 1e-9 (stationary to precision)"
            if again.fun < best.fun:
                best = again
        theta = best.x * self._scale
        final = self._objective(theta)
        self.converged_ = bool(success and final is not None and best.fun < self._penalty)
        self.message_ = message
        if not self.converged_:
            warnings.warn(f"identification did not converge: {self.message_}", RuntimeWarning, stacklevel=2)
        theta = self._absolute_std(theta)
        self.theta_ = theta
        self.cost_ = float(final[0]) if final is not None else float("nan")
        self.n_iter_, self.n_eval_ = int(n_iter), int(n_eval)
        self.moments_ = final[2] if final is not None else None
        self.theta_std_ = self._gauss_newton_std(self.model.moments(theta, gradient=True)) if final is not None else np.full(theta.size, np.nan)
        self.gauss_newton_std_ = self.theta_std_
        self.upper_bounds_, self.misfit_reference_ = {}, None
        return self

    def _absolute_std(self, theta):
        theta = np.array(theta, float)
        for i, name in enumerate(self.model.theta_names):
            if name.endswith("_std"):
                theta[i] = abs(theta[i])  # the cost is even in sigma (FACTS)
        return theta

    def at_zero(self) -> list[int]:
        """Indices of the stds estimated at the lower bound of their box (no spread)."""
        lo, hi = np.array(self.bounds, float).T
        return [i for i, name in enumerate(self.model.theta_names)
                if name.endswith("_std") and self.theta_[i] <= lo[i] + 1e-6 * (hi[i] - lo[i])]

    def _sampling_errors(self, runs) -> None:
        """Sandwich standard errors and the misfit's reference from the realisations ``runs``
        (:func:`uqdrive.inference.sampling.sampling_errors`; a std at zero gets a one-sided bound)."""
        if self.moments_ is None:
            return
        if runs.ndim != 3 or runs.shape[0] != self._mean.shape[0] or runs.shape[2] != self._mean.shape[1]:
            raise ValueError(f"runs must have shape (n_states, n, T) = ({self._mean.shape[0]}, n, {self._mean.shape[1]}), got {runs.shape}")
        _, jac = self._weighted_residuals(self.model.moments(self.theta_, gradient=True), jacobian=True)
        zero = self.at_zero()
        self.theta_std_, upper, self.misfit_reference_ = sampling_errors(jac, run_influence(runs, self._w), self.theta_, zero, self.rng)
        self.upper_bounds_ = {self.model.theta_names[i]: u for i, u in upper.items()}

    def _global_candidates(self):
        if self.starts <= 0:
            return []
        lo, hi = np.array(self.bounds, float).T
        # Candidates within a factor of the box centre of mass: physical and not extreme.
        n = 24 * self.starts
        cand = lo + (hi - lo) * self.rng.random((n, lo.size))
        scored = []
        for c in cand:
            if "F_w_mean_low" in self.model.theta_names:  # keep low < high
                i, j = self.model.theta_names.index("F_w_mean_low"), self.model.theta_names.index("F_w_mean_high")
                c[i], c[j] = min(c[i], c[j]), max(c[i], c[j])
            out = self._objective(c, gradient=False)
            if out is not None:
                scored.append((out[0], c))
        scored.sort(key=lambda s: s[0])
        return [c for _, c in scored[: self.starts]]

    def _weighted_residuals(self, r, jacobian: bool = False):
        """Residuals of (5.25), sqrt(w) [mean error, std error] flattened (n,), and with
        ``jacobian`` their derivative (n, p) from the model's sensitivities."""
        std = np.sqrt(np.maximum(r.variance + self._nv, 1e-300))
        sw = np.sqrt(self._w)
        res = np.concatenate([(sw * (r.mean - self._mean)).ravel(), (sw * (std - self._std)).ravel()])
        if not jacobian:
            return res
        Jm = (sw * r.mean_gradient).reshape(r.mean_gradient.shape[0], -1)
        Js = (sw * r.variance_gradient / (2.0 * std)).reshape(r.variance_gradient.shape[0], -1)
        return res, np.concatenate([Jm, Js], axis=1).T

    def _gauss_newton_std(self, r) -> np.ndarray:
        return gauss_newton_errors(*self._weighted_residuals(r, jacobian=True))

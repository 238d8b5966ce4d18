"""When a least-squares fit of the discrepancy search has converged as far as the chi2 comparison
can tell: the decrease its Gauss-Newton model still predicts, against the null band's resolution.
"""

from __future__ import annotations

import numpy as np

from .ranking import gauss_newton_chi2

__all__ = ["RESOLVED_SHARE", "RESOLVED_TIMES", "ResolutionRule", "ResolutionStop", "predicted_decrease"]

#: A fit stops when the decrease of chi2 its Gauss-Newton model predicts is below this share of the
#: null band's chi2 standard deviation ...
RESOLVED_SHARE = 0.05
#: ... at this many consecutive accepted points.
RESOLVED_TIMES = 2


def predicted_decrease(jac, f, lower, upper) -> float:
    """The decrease of chi2 = |f|^2 the Gauss-Newton model predicts within the bounds.

    min over lower <= d <= upper of |f + J d|^2, subtracted from |f|^2: the linearised model's
    whole remaining decrease, not one trust-region step's, so a search that crawls (steps cut
    short by the trust region or by curvature) still predicts the decrease it has not made.

    Parameters
    ----------
    jac : ndarray, shape (m, p)
        d f / d parameters at the point.
    f : ndarray, shape (m,)
        Residuals at the point (chi2 units: their squares sum to chi2).
    lower, upper : ndarray, shape (p,)
        Bounds of the step d (the parameters' bounds less the point; lower <= 0 <= upper).

    Returns
    -------
    float
        |f|^2 - min |f + J d|^2 >= 0.
    """
    f = np.asarray(f, float)
    if not (np.all(np.isfinite(jac)) and np.all(np.isfinite(f))):
        return float("inf")  # no model to trust: never a reason to stop
    return max(float(f @ f) - gauss_newton_chi2(f, jac, lower, upper), 0.0)


class ResolutionStop(Exception):
    """Raised inside a least-squares search when it has converged to the chi2 comparison's
    resolution: the point and its Jacobian (trf's variables)."""

    def __init__(self, point, jac):
        super().__init__("the remaining predicted decrease of chi2 is below the comparison's resolution")
        self.point, self.jac = np.asarray(point, float), np.asarray(jac, float)


class ResolutionRule:
    """The stop of one search: :data:`RESOLVED_TIMES` consecutive accepted points whose
    :func:`predicted_decrease` is below ``tolerance`` (chi2 units)."""

    def __init__(self, tolerance: float, lower, upper, times: int = RESOLVED_TIMES):
        self.tolerance, self.times = float(tolerance), int(times)
        self.lower, self.upper = np.asarray(lower, float), np.asarray(upper, float)
        self.count = 0

    def check(self, point, jac, f) -> None:
        """Count the point (its Jacobian ``jac`` and residuals ``f``); raise
        :class:`ResolutionStop` at the last of the consecutive resolved points."""
        point = np.asarray(point, float)
        resolved = predicted_decrease(jac, f, self.lower - point, self.upper - point) < self.tolerance
        self.count = self.count + 1 if resolved else 0
        if self.count >= self.times:
            raise ResolutionStop(point, jac)

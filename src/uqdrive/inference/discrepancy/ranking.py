"""What a least-squares fit would still reach, by its first-order (Gauss-Newton) model: candidate
effects ranked before their joint fits, and a fit stopped once the rest is below the comparison's resolution.

A candidate fitted with the distributions held at an estimate that has absorbed its signature
lowers chi2 by nothing; the first-order (Gauss-Newton) prediction of its joint fit, with the
distributions and the effects already added free, does not miss it and costs no simulation.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import least_squares, lsq_linear

__all__ = ["HOPELESS_OPTIMISM", "RESOLVED_SHARE", "RESOLVED_TIMES", "ResolutionRule", "ResolutionStop", "gauss_newton_chi2",
           "joint_prediction", "predicted_decrease", "resolved_least_squares", "screen"]


def gauss_newton_chi2(z, jacobian, lower=None, upper=None) -> float:
    """The chi2 one Gauss-Newton step reaches: min over d of |z + J d|^2, lower <= d <= upper.

    The first-order prediction of a least-squares fit of all of J's parameters from the point
    with standardised residuals z (the Gauss-Newton model, Nocedal & Wright (10.23), with the
    parameters' bounds as bounds on the step: a parameter on its bound moves away from it only).
    With J the Jacobian of the distributions, the effects already fitted and a new candidate's
    parameters it predicts how far a joint fit lowers chi2 (the score test's measure): the
    parameters the candidate is confounded with move along, their share of its signature
    projected out.

    Parameters
    ----------
    z : ndarray, shape (M,)
        Standardised residuals (-) at the point.
    jacobian : ndarray, shape (M, p)
        d z / d parameters there; all-zero columns (known parameters) are left out, the others
        normalised (the prediction does not depend on the parameters' units).
    lower, upper : ndarray, shape (p,), optional
        Bounds of the step (parameter bound minus value, in the parameters' units); default
        unbounded.

    Returns
    -------
    float
        min |z + J d|^2 over the allowed steps, at most |z|^2.
    """
    z, jac = np.asarray(z, float), np.asarray(jacobian, float)
    p = jac.shape[1]
    lower = np.full(p, -np.inf) if lower is None else np.minimum(np.asarray(lower, float), 0.0)
    upper = np.full(p, np.inf) if upper is None else np.maximum(np.asarray(upper, float), 0.0)
    norm = np.linalg.norm(jac, axis=0)
    keep = norm > 0
    if not keep.any():
        return float(z @ z)
    jac, norm = jac[:, keep] / norm[keep], norm[keep]
    step = lsq_linear(jac, -z, bounds=(lower[keep] * norm, upper[keep] * norm), method="bvls")
    r = z + jac @ step.x
    return float(min(r @ r, z @ z))


def joint_prediction(current, held) -> float:
    """The chi2 one Gauss-Newton step of a joint fit reaches from a candidate's held fit.

    Parameters
    ----------
    current : StructureFit
        The fitted model the candidate is added to (distributions and effects fitted; its
        ``jacobian_`` in units of its own ``scale_``).
    held : StructureFit
        The candidate's own parameters fitted on top of ``current`` with the distributions and
        effects held at ``current``'s values (``fit_theta=False``).

    Returns
    -------
    float
        :func:`gauss_newton_chi2` of ``held``'s standardised gap over ``current``'s parameters
        (converted to ``held``'s scale) and the candidate's, each step within its bounds;
        ``held.chi2_`` when ``current`` fitted nothing.
    """
    if not current.jacobian_.size:
        return float(held.chi2_)
    unit = current.scale_.ravel() / held.scale_.ravel()  # d z / d p from the current model's scale to the held fit's
    jac = np.hstack([current.jacobian_ * unit[:, None], held.jacobian_])
    at = np.concatenate([current.theta_, current.effect_values_, held.effect_values_])
    lo, hi = (np.concatenate(b) for b in zip(current.parameter_bounds, held.parameter_bounds))
    return gauss_newton_chi2(held.z_.ravel(), jac, lo - at, hi - at)


def screen(current, names, anchors, held, fixed=None) -> dict:
    """Rank candidate effects by what their joint fit with ``current`` would reach.

    Each candidate's own parameters are fitted with the distributions and the effects already
    added held, at each anchor. At ``"current"`` (``current``'s distributions) the score is the
    Gauss-Newton prediction of the joint fit from there (:func:`joint_prediction`): held alone,
    a candidate whose signature the distributions absorbed lowers chi2 by nothing (after an
    addition, a mean-wind range widened to stand in for stronger gusts, or a mu lowered to stand
    in for a roll steer) while its joint fit closes most of the gap. At another anchor the score
    is the held chi2, a point the joint fit can reach. The best score ranks the candidate, and
    its joint fit starts at that held fit.

    Parameters
    ----------
    current : StructureFit
        The model the candidates are added to.
    names : sequence of str
        Registry names of the candidates.
    anchors : mapping of str to ndarray, shape (6,)
        Distribution parameters to hold (label -> theta), ``"current"`` among them.
    held : callable
        ``held(name, theta)`` -> the candidate's held fit (a fitted :class:`.fit.StructureFit`).
    fixed : mapping of str to sequence of float, optional
        Candidates not screened (fitted jointly anyway: the numerically integrated ones) with
        their start values; score NaN.

    Returns
    -------
    dict
        name -> {"chi2": score, "held": held chi2 at that anchor, "values": ndarray (the
        candidate's parameters), "theta": ndarray, shape (6,), "anchor": label}.
    """
    fixed = dict(fixed or {})
    out = {}
    for name in names:
        if name in fixed:
            out[name] = {"chi2": float("nan"), "held": float("nan"), "values": np.asarray(fixed[name], float),
                         "theta": np.asarray(current.theta_, float), "anchor": "current"}
            continue
        for label, theta in anchors.items():
            f = held(name, theta)
            score = joint_prediction(current, f) if label == "current" else float(f.chi2_)
            if name not in out or score < out[name]["chi2"]:
                out[name] = {"chi2": score, "held": float(f.chi2_), "values": f.effect_values_, "theta": f.theta_, "anchor": label}
    return out


#: A candidate's fit stops when the decrease of chi2 its Gauss-Newton model predicts is below this
#: share of the null band's chi2 standard deviation (sd) at RESOLVED_TIMES consecutive accepted
#: points. Every choice compares chi2 differences with a margin of 2 sd, so the rest is at most a
#: fortieth of it; the rest of the step is sqrt(rest) in the Gauss-Newton metric, sqrt(rest /
#: inflation) standard deviations of a reported interval (0.48 at the combined saturation-and-lag
#: case's sd 75 and inflation 16, a bound; its fits moved by at most 0.01 of them). On the
#: 35 benchmark discovers and 45 detection cells every verdict stays; a fit's chi2 or a ranking
#: score moves by at most 0.4 sd, a screening's held chi2 by up to 1.7 sd (combined_bank_bias, step
#: 2: held at the first step's fit, which stopped a little elsewhere, a held fit of 40 evaluations
#: ends elsewhere too; that candidate's score moved 0.04 sd). A per-step relative criterion (trf's
#: ftol at 1e-5) stops a search that creeps in small steps: on actuator_delay_150ms's baseline it
#: moves the band's inflation from 25.5 to 15.1.
RESOLVED_SHARE = 0.05
#: Consecutive points: one point's prediction may be a chance low of a rough Jacobian; the second
#: confirms it after a step that made (nearly) the predicted decrease.
RESOLVED_TIMES = 2
#: A fit asked to come below a chi2 (``hopeless_above``: the bar where its result would change a
#: choice) stops when even this multiple of its Gauss-Newton model's predicted decrease leaves it
#: above the bar, at RESOLVED_TIMES consecutive accepted points: the fit cannot matter, its end
#: would only be reported. The first-order model is a guide, not a bound, on a non-linear
#: model: the probes of a saturating tyre that ended below their bar on ten benchmark discovers
#: (178 evaluations) needed at most 1.02 times their points' predicted decrease to get there (a
#: fit far from its optimum on a curved valley reaches further than its model predicts); twice
#: that leaves a factor of two, and stops 20 of 42 probes that cannot matter, a quarter of the
#: probes' evaluations.
HOPELESS_OPTIMISM = 2.0


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
    resolution (``status`` 5) or cannot come below the chi2 it was asked for (``status`` 6): the
    point and its Jacobian (trf's variables)."""

    RESOLVED, OUT_OF_REACH = 5, 6
    MESSAGES = {RESOLVED: "the remaining predicted decrease of chi2 is below the comparison's resolution",
                OUT_OF_REACH: "chi2 stays above the bar the fit was asked to reach, by twice its predicted decrease"}

    def __init__(self, point, jac, status: int = RESOLVED):
        super().__init__(self.MESSAGES[status])
        self.point, self.jac, self.status = np.asarray(point, float), np.asarray(jac, float), int(status)


class ResolutionRule:
    """The stops of one search: :data:`RESOLVED_TIMES` consecutive accepted points whose
    :func:`predicted_decrease` is below ``tolerance`` (chi2 units; None: never), or whose chi2
    less :data:`HOPELESS_OPTIMISM` times that decrease stays above ``hopeless_above`` (chi2 units;
    None: never)."""

    def __init__(self, tolerance: float | None, lower, upper, times: int = RESOLVED_TIMES, hopeless_above: float | None = None):
        self.tolerance = None if tolerance is None else float(tolerance)
        self.above = None if hopeless_above is None else float(hopeless_above)
        self.times = int(times)
        self.lower, self.upper = np.asarray(lower, float), np.asarray(upper, float)
        self.count = self.hopeless = 0

    def check(self, point, jac, f) -> None:
        """Count the point (its Jacobian ``jac`` and residuals ``f``); raise
        :class:`ResolutionStop` at the last of the consecutive resolved or hopeless points."""
        point = np.asarray(point, float)
        rest = predicted_decrease(jac, f, self.lower - point, self.upper - point)
        resolved = self.tolerance is not None and rest < self.tolerance
        self.count = self.count + 1 if resolved else 0
        if self.count >= self.times:
            raise ResolutionStop(point, jac, ResolutionStop.RESOLVED)
        out_of_reach = self.above is not None and float(np.dot(f, f)) - HOPELESS_OPTIMISM * rest > self.above
        self.hopeless = self.hopeless + 1 if out_of_reach else 0
        if self.hopeless >= self.times:
            raise ResolutionStop(point, jac, ResolutionStop.OUT_OF_REACH)


def resolved_least_squares(fun, jac, x0, bounds, x_scale, max_nfev: int, resolution: float | None, hopeless_above: float | None = None):
    """trf (``xtol = ftol = 1e-8``, at most ``max_nfev`` evaluations of ``fun``) stopped by a
    :class:`ResolutionRule` of tolerance ``resolution`` (chi2; None: trf's tolerances alone) and
    bar ``hopeless_above`` (chi2; None: none), checked wherever trf asks for the Jacobian (at every
    point it accepts).

    Returns
    -------
    x, jacobian, nfev, status, message
        trf's; a resolution stop has status 5, a hopeless one 6, and the stopped point's Jacobian.
    """
    calls, last = [0], {}
    rule = None if resolution is None and hopeless_above is None else ResolutionRule(resolution, *bounds, hopeless_above=hopeless_above)

    def counted(x):
        calls[0] += 1
        last["x"], last["f"] = np.array(x, float), fun(x)
        return last["f"]

    def checked(x):
        j = jac(x)
        if rule is not None:  # trf evaluates the residuals of a point before its Jacobian
            rule.check(x, j, last["f"] if np.array_equal(last.get("x"), x) else fun(x))
        return j

    try:
        res = least_squares(counted, x0, jac=checked, bounds=bounds, x_scale=x_scale, method="trf", max_nfev=max_nfev, xtol=1e-8, ftol=1e-8)
        return res.x, res.jac, int(res.nfev), int(res.status), str(res.message)
    except ResolutionStop as stop:
        return stop.point, stop.jac, calls[0], stop.status, str(stop)

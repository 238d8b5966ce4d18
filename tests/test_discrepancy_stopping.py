"""The resolution stop of the candidates' fits: the decrease the Gauss-Newton model still predicts,
not the last step's, so a search that crawls is not stopped; a fit stopped there is within the
resolution of the one run to trf's tolerances, with fewer evaluations."""

import numpy as np
import pytest

from uqdrive.inference.discrepancy.fit import StructureFit
from uqdrive.inference.discrepancy.ranking import RESOLVED_TIMES, ResolutionRule, ResolutionStop, predicted_decrease
from uqdrive.vehicle.effects import EFFECTS, ModelStructure

from test_discrepancy_fit import TRUTH, _Analytic, _measured

RNG = np.random.default_rng(3)
A = RNG.standard_normal((40, 3))
B = A @ np.array([1.0, -2.0, 0.5]) + 0.1 * RNG.standard_normal(40)  # chi2 at the optimum > 0
OPT = np.linalg.lstsq(A, B, rcond=None)[0]
CHI2_MIN = float(np.sum((A @ OPT - B) ** 2))


def _f(x):
    return A @ x - B


def road_bank_fit(**stops):
    """A joint fit of the distributions and a road bank (2 m/s^2) from far off on the analytic
    stand-in, noise so that chi2 at the optimum is not 0, with the fit's ``stops`` (resolution,
    hopeless_above)."""
    sim = _Analytic()
    a_lat = EFFECTS["road_bank"].augment(ModelStructure(), [2.0]).lateral_acceleration
    measured = _measured(sim, TRUTH, a_lat) + 1e-2 * np.random.default_rng(8).standard_normal((2, 4, 12))
    return StructureFit(sim, np.arange(12), np.zeros(4), effect=EFFECTS["road_bank"], max_nfev=200, **stops).fit(
        measured, np.full_like(measured, 1e-2), theta0=[1.2, 0.3, 1.3, 0.3, -400.0, 400.0], effect_start=[0.5])


def test_predicted_decrease_of_a_linear_problem_is_its_whole_remaining_decrease():
    """For f linear in x the Gauss-Newton model is exact: the prediction at any point is chi2 there
    less chi2 at the optimum (1e-9 relative: one QR solve); a bound the optimum lies beyond caps it
    at the bounded optimum's, which is smaller."""
    x = np.array([3.0, 1.0, -1.0])
    chi2 = float(_f(x) @ _f(x))
    free = predicted_decrease(A, _f(x), np.full(3, -np.inf), np.full(3, np.inf))
    assert free == pytest.approx(chi2 - CHI2_MIN, rel=1e-9)
    capped = predicted_decrease(A, _f(x), np.array([-np.inf, 0.0, -np.inf]), np.full(3, np.inf))  # x1 may not fall to -2
    assert 0.0 < capped < free - 1.0
    assert predicted_decrease(A, _f(OPT), np.full(3, -np.inf), np.full(3, np.inf)) == pytest.approx(0.0, abs=1e-9)
    assert predicted_decrease(A, np.full(40, np.nan), np.full(3, -1.0), np.full(3, 1.0)) == np.inf


def test_a_crawl_is_not_stopped_where_a_relative_change_criterion_would_stop_it():
    """300 points that creep towards the optimum by 2e-4 of the remaining way per step (a trust
    region cut short, as a spread creeping to zero): each step lowers chi2 by less than 1e-3
    relative, where a per-step criterion would stop, 80 % of the decrease still to come; the rule
    does not stop on them. Near the optimum (within its tolerance) it stops on the
    RESOLVED_TIMES-th point, not before."""
    x0, tol = np.array([3.0, 1.0, -1.0]), 0.5
    rule = ResolutionRule(tol, np.full(3, -10.0), np.full(3, 10.0))
    crawl = [x0 + (1.0 - (1.0 - 2e-4) ** k) * (OPT - x0) for k in range(300)]
    chi2 = np.array([float(_f(x) @ _f(x)) for x in crawl])
    assert np.all(-np.diff(chi2) / chi2[:-1] < 1e-3) and chi2[-1] - CHI2_MIN > 0.8 * (chi2[0] - CHI2_MIN)
    for x in crawl:
        rule.check(x, A, _f(x))  # raises if it stops
    near = [OPT + 1e-3 * (k + 1) for k in range(RESOLVED_TIMES)]
    assert all(float(_f(x) @ _f(x)) - CHI2_MIN < tol for x in near)
    for x in near[:-1]:
        rule.check(x, A, _f(x))
    with pytest.raises(ResolutionStop) as stop:
        rule.check(near[-1], A, _f(near[-1]))
    np.testing.assert_array_equal(stop.value.point, near[-1])


def test_an_unresolved_point_restarts_the_count():
    """Resolved, unresolved, resolved: no stop (the count restarts); a second resolved point stops."""
    rule = ResolutionRule(1.0, np.full(3, -10.0), np.full(3, 10.0), times=2)
    near, far = OPT + 1e-4, OPT + 1.0
    for x in (near, far, near):
        rule.check(x, A, _f(x))
    with pytest.raises(ResolutionStop):
        rule.check(near, A, _f(near))


def test_a_fit_stopped_at_its_resolution_is_within_it_with_fewer_evaluations():
    """A joint fit of the distributions and a road bank from far off (the analytic stand-in,
    noise so that chi2 at the optimum is not 0): with a resolution of 1 (chi2) it stops with fewer
    evaluations than the fit to trf's tolerances, its chi2 above that fit's by less than the
    resolution (the Gauss-Newton model near the optimum is quadratic to within this margin);
    a resolution of 1e-12 runs the whole fit and gives its numbers."""
    def fit(resolution):
        return road_bank_fit(resolution=resolution)

    full, stopped, tight = fit(None), fit(1.0), fit(1e-12)
    assert full.chi2_ > 10.0
    assert stopped.nfev_ < full.nfev_ and stopped.success_
    assert 0.0 <= stopped.chi2_ - full.chi2_ < 1.0
    assert tight.chi2_ == pytest.approx(full.chi2_, rel=1e-9)


def test_a_wide_footing_fit_resolves_at_the_linear_footings_resolution_divided_by_its_squared_scale_ratio():
    """The comparison multiplies a numerically integrated fit's chi2 excess by its squared scale
    ratio (here 4: the scale doubled), so its tolerance in its own chi2 is a quarter; none is set
    before the band is known (the baseline's fit)."""
    from types import SimpleNamespace

    from uqdrive.inference.discrepancy.fitter import CandidateFitter
    from uqdrive.inference.discrepancy.ranking import RESOLVED_SHARE

    scale = np.ones((2, 4, 12))
    data = SimpleNamespace(scale=scale, scale_for=lambda wide: 2.0 * scale if wide else scale)
    fitter = CandidateFitter(data, {}, TRUTH, 0.97, 3)
    assert fitter._resolution(False) is None and fitter._resolution(True) is None
    fitter.resolve_at(SimpleNamespace(chi2_null_sd=80.0))
    assert fitter._resolution(False) == pytest.approx(RESOLVED_SHARE * 80.0, rel=1e-12)
    assert fitter._resolution(True) == pytest.approx(RESOLVED_SHARE * 80.0 / 4.0, rel=1e-12)

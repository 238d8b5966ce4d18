"""The hopeless stop of the candidates' fits: a fit asked to come below a chi2 stops where even
twice its Gauss-Newton model's predicted decrease leaves it above; a bar it can reach never
stops it; the bars are the thresholds of the choices they stand for (a probe's reach, the
backward check's removal), on the footing of the fit's own scale."""

from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from uqdrive.inference.discrepancy.comparison import ModelComparison
from uqdrive.inference.discrepancy.fitter import PROBE_SHARE, in_reach, reach_bar
from uqdrive.inference.discrepancy.ranking import HOPELESS_OPTIMISM, RESOLVED_TIMES, ResolutionRule, ResolutionStop
from uqdrive.inference.discrepancy.selection import _removal_bar, comparison_margin
from uqdrive.vehicle.effects import EFFECTS

from test_discrepancy_fit import TRUTH
from test_discrepancy_stopping import CHI2_MIN, OPT, A, _f, road_bank_fit

FREE = (np.full(3, -np.inf), np.full(3, np.inf))


def _path(n=40):
    """Points from far off to the optimum of the linear problem (chi2 falling to CHI2_MIN)."""
    x0 = np.array([3.0, 1.0, -1.0])
    return [x0 + (1.0 - 0.7**k) * (OPT - x0) for k in range(n)]


def test_a_bar_the_fit_reaches_never_stops_it(monkeypatch):
    """On a linear problem the Gauss-Newton prediction is the whole remaining decrease, so chi2 less
    twice of it is 2 CHI2_MIN - chi2 <= CHI2_MIN: a bar just above the optimum's chi2 is never out
    of reach at any point of the way; an optimism below 1 (trusting the model for half its
    prediction) would stop the fit on its far points, bar or no bar within reach."""
    assert HOPELESS_OPTIMISM >= 1.0
    rule = ResolutionRule(None, *FREE, hopeless_above=CHI2_MIN + 1e-6)
    for x in _path():
        rule.check(x, A, _f(x))
    monkeypatch.setattr("uqdrive.inference.discrepancy.ranking.HOPELESS_OPTIMISM", 0.5)
    timid = ResolutionRule(None, *FREE, hopeless_above=CHI2_MIN + 1e-6)
    with pytest.raises(ResolutionStop):
        for x in _path():
            timid.check(x, A, _f(x))


def test_a_bar_below_the_optimum_stops_on_the_consecutive_points_near_it_and_a_far_point_restarts_the_count():
    """A bar 1 below the optimum's chi2: near the optimum (chi2 within 1 of it) even twice the rest
    leaves chi2 above the bar; far off, twice the rest reaches below it (not hopeless: the count
    restarts). Near, far, near: no stop; the RESOLVED_TIMES-th near point in a row stops with status 6."""
    rule = ResolutionRule(None, *FREE, hopeless_above=CHI2_MIN - 1.0)
    near, far = OPT + 1e-4, _path()[0]
    for x in (near, far, near):
        rule.check(x, A, _f(x))
    assert RESOLVED_TIMES == 2
    with pytest.raises(ResolutionStop) as stop:
        rule.check(near, A, _f(near))
    assert stop.value.status == 6 and "bar" in str(stop.value)


def test_a_hopeless_fit_stops_early_above_its_bar_and_a_reachable_bar_changes_nothing():
    """A joint fit of the distributions and a road bank from far off (the analytic stand-in, noise
    so that chi2 at the optimum is F > 0): asked to come below F / 2, out of its reach, it stops
    with fewer evaluations, not converged, above the bar (as the whole fit ends); asked to come
    below 2 F, which it reaches, it gives the whole fit's numbers bit for bit."""
    def fit(bar):
        return road_bank_fit(hopeless_above=bar)

    full = fit(None)
    assert full.chi2_ > 10.0 and full.success_
    hopeless, reachable = fit(0.5 * full.chi2_), fit(2.0 * full.chi2_)
    assert hopeless.nfev_ < full.nfev_ and not hopeless.success_ and "bar" in hopeless.message_
    assert hopeless.chi2_ >= full.chi2_ > 0.5 * full.chi2_
    assert reachable.chi2_ == full.chi2_ and reachable.nfev_ == full.nfev_ and reachable.success_


class _Chi2:
    """A comparison whose chi2 of a fit is the fit's own number."""

    @staticmethod
    def chi2(fit):
        return fit.c


@settings(max_examples=200, deadline=None)
@given(cur=st.floats(1.0, 1e6), closes=st.lists(st.floats(-0.5, 1.0), min_size=0, max_size=3), probe=st.floats(0.0, 1.2))
def test_a_probe_is_in_reach_exactly_below_its_bar(cur, closes, probe):
    """in_reach: the probe closed at least PROBE_SHARE of the best linear candidate's gain, or no
    linear candidate gained (no bar: every probe finishes); the bar is that threshold."""
    others = [SimpleNamespace(c=cur * (1.0 - s)) for s in closes]
    p = SimpleNamespace(c=cur * (1.0 - probe))
    gain = cur - min((o.c for o in others), default=cur)
    bar = reach_bar(_Chi2, SimpleNamespace(c=cur), others)
    assert (bar is None) == (gain <= 0)
    assert in_reach(_Chi2, SimpleNamespace(c=cur), p, others) == (gain <= 0 or cur - p.c >= PROBE_SHARE * gain)
    if bar is not None:
        assert bar == pytest.approx(cur - PROBE_SHARE * gain, rel=1e-12)


def _comparison(ratio=2.0, null=1.1, footing_null=1.4):
    """A ModelComparison of scale 1 whose wide scale is ``ratio`` times it, its bands' mean squares given."""
    scale = np.ones((2, 3, 10))
    data = SimpleNamespace(scale=scale, scale_for=lambda wide: ratio * scale if wide else scale)
    band = SimpleNamespace(mean_square_null=null, chi2_null_sd=7.0, inflation=1.5)
    footing = SimpleNamespace(mean_square_null=footing_null, chi2_null_sd=9.0, inflation=2.0)
    return ModelComparison(band, scale, footing, SimpleNamespace(data=data)), data


def _fit(c, scale):
    return SimpleNamespace(chi2_=c, scale_=scale, z_=np.zeros_like(scale), theta_=TRUTH)


@settings(max_examples=300, deadline=None)
@given(c=st.floats(0.0, 1e5), bar=st.floats(0.0, 1e5), ratio=st.sampled_from([1.0, 1.5, 3.0]))
def test_the_bar_on_a_fits_own_scale_inverts_the_common_footings_conversion(c, bar, ratio):
    """chi2 of a fit on the common footing (ModelComparison.chi2) is above a bar exactly where its
    own chi2 is above chi2_bar(bar, wide), on either branch of the conversion (an excess times the
    squared scale ratio, a chi2 below the null level as it is) and for a linear fit (the bar itself)."""
    comparison, data = _comparison(ratio)
    on = comparison.chi2_bar(bar, True)
    if abs(c - on) > 1e-7 * max(1.0, abs(on)):
        assert (comparison.chi2(_fit(c, data.scale_for(True))) > bar) == (c > on)
    assert comparison.chi2_bar(bar, False) == bar


@pytest.mark.parametrize("wide", [False, True])
@pytest.mark.parametrize("name", ["road_bank", "lateral_kinematics"])
def test_the_removal_bar_is_the_backward_checks_threshold(wide, name):
    """backward_check removes an effect when its refit's chi2 on the common footing exceeds the
    current fit's by at most the effect's penalty plus the footings' margin: a refit just below
    the bar (on its own scale) is removed, just above it kept, on the linear and the wide footing,
    for an effect with a physical value (lateral_kinematics) and one without."""
    comparison, data = _comparison()
    cur = _fit(500.0, data.scale_for(False))
    margin, per_param = 14.0, 3.0
    bar = _removal_bar(comparison, SimpleNamespace(data=data), cur, name, margin, per_param)(wide)
    for c, removed in ((bar * (1 - 1e-9), True), (bar * (1 + 1e-9), False)):
        refit = _fit(c, data.scale_for(wide))
        saved = comparison.chi2(refit) - comparison.chi2(cur) - per_param * len(EFFECTS[name].parameters)
        assert (saved <= comparison_margin(comparison, name, margin, refit, cur)) == removed


def test_a_probe_stopped_out_of_reach_is_finished_as_without_the_stop_when_asked():
    """fit_pool hands each non-linear probe the reach bar (here 100 - 0.25 x 60 = 85: the linear
    candidate closed 60 of 100); a probe stopped there (its fit says so) is kept as it stopped, at
    95, and recorded; finish() fits it again without the bar (its end, 90, still above the bar:
    not finished further) and clears the record. Where the linear candidate closed nothing there
    is no bar and nothing stops (the probe in reach is finished by a full fit)."""
    from uqdrive.inference.discrepancy.effectset import EffectSet
    from uqdrive.inference.discrepancy.fitter import PROBE_NFEV, CandidateFitter
    from uqdrive.inference.discrepancy.ranking import ResolutionStop

    comparison, data = _comparison(ratio=1.0)
    one = data.scale_for(False)
    calls = []

    def joint(theta, names, values, max_nfev=None, release=(), hopeless_above=None):
        bar = None if hopeless_above is None else hopeless_above(True)
        calls.append((tuple(names), max_nfev, bar))
        if names[-1] == "road_bank":
            return SimpleNamespace(chi2_=closed_to, scale_=one, z_=np.zeros_like(one), theta_=TRUTH, message_="")
        stopped = bar is not None
        return SimpleNamespace(chi2_=95.0 if stopped else 90.0, scale_=one, z_=np.zeros_like(one), theta_=TRUTH,
                               status_=ResolutionStop.OUT_OF_REACH if stopped else 1, effect=EffectSet(["tyre_saturation"]), effect_values_=np.ones(1))

    fitter = CandidateFitter(SimpleNamespace(delta=np.zeros(100), dt=0.01, scale_for=lambda wide: one), {}, TRUTH, 0.97, top=1)
    fitter.joint = joint
    cur = _fit(100.0, one)
    screening = {c: {"chi2": 0.0, "theta": TRUTH, "values": [0.0]} for c in ("road_bank", "tyre_saturation")}
    margin_band = SimpleNamespace(chi2_null_sd=1.0, inflation=1.0)
    for closed_to, bar in ((40.0, 85.0), (100.0, None)):
        calls.clear()
        fits, tried = fitter.fit_pool(comparison, cur, margin_band, ["road_bank", "tyre_saturation"], screening, [], {})
        assert tried == ["road_bank", "tyre_saturation"] and fitter.reach_bar == bar
        probes = [c for c in calls if c[0] == ("tyre_saturation",) and c[1] == PROBE_NFEV]
        assert [c[2] for c in probes] == [bar, bar]  # both starts, each told the bar
        if bar is None:
            assert fitter.unfinished == {} and fits["tyre_saturation"].chi2_ == 90.0
            continue
        assert fits["tyre_saturation"].chi2_ == 95.0 and list(fitter.unfinished) == ["tyre_saturation"]
        finished = fitter.finish(fits)
        assert finished["tyre_saturation"].chi2_ == 90.0 and fits["tyre_saturation"].chi2_ == 95.0 and fitter.unfinished == {}
        assert finished["road_bank"] is fits["road_bank"]

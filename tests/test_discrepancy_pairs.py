"""Two rules of the forward selection, on stand-in fits: the pair step (two missing effects that
only together close their share of the gap; standardised gaps built from orthogonal parts, a's,
b's and an unexplained rest's share of the excess misfit chosen per case), and the size check
(a named effect's interval must not hold the value at which it vanishes)."""

from types import SimpleNamespace

import numpy as np
import pytest

from uqdrive.inference.discrepancy import selection
from uqdrive.inference.discrepancy.band import NullBand, excess_rms, scan_windows
from uqdrive.inference.discrepancy.comparison import ModelComparison
from uqdrive.inference.discrepancy.effectset import EffectSet
from uqdrive.inference.discrepancy.fitter import CandidateFitter
from uqdrive.vehicle.effects import ModelStructure

K = 60
THETA = np.array([1.0, 0.2, 1.55, 0.2, -400.0, 400.0])
A, B, C = "road_bank", "wind_gust", "sensor_bias_psi_dot"
ONE = np.ones(480)  # the scale of the stand-ins with 480 cells (all on the linear models' footing)


def _parts(rng):
    """Three orthonormal rough patterns (2, 4, K), unit mean square each, and a null-like noise."""
    q, _ = np.linalg.qr(rng.standard_normal((2 * 4 * K, 3)))
    return [v.reshape(2, 4, K) * np.sqrt(v.size) for v in q.T], 0.3 * rng.standard_normal((2, 4, K))


class _Search(SimpleNamespace):
    """A forward selection over ``candidates`` (at most ``max_effects``) with ``comparison`` and ``fitter``."""

    def forward(self, base, band):
        return selection.forward_selection(self.comparison, self.fitter, self.candidates, self.max_effects, base, band, {}, lambda *a: None)


def _stand_in_search(candidates, band, scale, joint):
    """A search over ``candidates`` whose joint fits are ``joint``, every band ``band`` (no
    bootstrap), every candidate screened alike, on the linear footing (``scale``: chi2 the fits' own)."""
    comparison = ModelComparison(band, scale, bands=SimpleNamespace(null=lambda fit, key=0: band))
    fitter = CandidateFitter(SimpleNamespace(delta=np.zeros(100), dt=0.01), {}, THETA, 0.97, top=3)
    fitter.joint = joint
    fitter.screen = lambda cur, pool: {c: {"chi2": 0.0, "held": 0.0, "theta": THETA, "values": [0.0], "anchor": "current"} for c in pool}
    return _Search(comparison=comparison, fitter=fitter, candidates=list(candidates), max_effects=3)


def _search(shares, pair_joins=True, excess=16.0, half=None):
    """A search whose joint fits are stand-ins: each candidate removes its own part of the gap
    (``shares``: the excess mean square of a, b and the rest), A with B together remove both
    (unless ``pair_joins`` is False: then B adds nothing on top of A), C removes nothing. Every
    fitted parameter's interval is 2 -+ ``half`` sqrt(factor) (``half`` by effect, default 0.1: a
    size told from none; the gust vanishes at 1, the others at 0)."""
    rng = np.random.default_rng(1)
    (u, w, r), noise = _parts(rng)
    band = NullBand.from_replicates(0.3 * rng.standard_normal((300, 2, 4, K)), scan_windows(K))
    amp = {k: np.sqrt(excess * s) for k, s in zip("abr", shares)}
    gap = {"a": amp["a"] * u, "b": amp["b"] * w, "r": amp["r"] * r}

    def fit(names, left):
        eff = EffectSet(names) if names else None
        z = noise + sum(gap[k] for k in left)
        widths = {p: (half or {}).get(p.split(".")[0], 0.1) for p in (eff.parameters if eff else ())}
        return SimpleNamespace(z_=z, chi2_=float(np.sum(z**2)), theta_=THETA, effect=eff, effect_values_=np.ones(len(eff.parameters) if eff else 0),
                               structure_=ModelStructure(), scale_=one,
                               effect_intervals=lambda factor=1.0: {p: [2.0, 2.0 - w * np.sqrt(factor), 2.0 + w * np.sqrt(factor)] for p, w in widths.items()})

    def joint(theta, names, values, max_nfev=None, release=(), **_):
        s = set(names)
        left = {"a", "b", "r"} - ({"a"} if A in s else set()) - ({"b"} if B in s and (pair_joins or A not in s) else set())
        calls.append(tuple(names))
        return fit(list(names), sorted(left))

    calls, one = [], np.ones_like(noise)
    s = _stand_in_search([A, B, C], band, one, joint)
    base = fit([], ["a", "b", "r"])
    return s, base, band, calls


@pytest.mark.parametrize("shares, named", [
    ((0.42, 0.38, 0.2), [A, B]),     # alone a closes 1 - sqrt(0.58) = 24 %, b 21 % (< 25 %); together 1 - sqrt(0.2) = 55 % (>= 44 %)
    ((0.25, 0.25, 0.5), []),        # together 1 - sqrt(0.5) = 29 %: not two additions' worth
    ((0.5, 0.3, 0.2), [A, B]),       # a alone closes 29 %: named alone, then b on top of it (1 - sqrt(0.2 / 0.5) = 37 %)
])
def test_a_pair_is_named_when_it_closes_two_additions_worth(shares, named):
    s, base, band, calls = _search(shares)
    gap0 = excess_rms(base.z_, band)
    steps = s.forward(base, band).steps
    assert [st.name for st in steps] == named
    if named and shares[0] < 0.4375:  # the pair step: both recorded as a pair, the partner with the pair's fit
        assert steps[0].pair == B and steps[1].pair == A
        assert (A, B) in calls
        assert steps[1].gap_after <= selection.STEP_SHRINK**2 * gap0


def test_a_pair_member_is_not_ambiguous_with_its_partner():
    """a and b close 22.5 % each alone, within the margin of each other: the first member's own
    fit ties with its partner's, but both are named, so the partner is no alternative to it."""
    s, base, band, _ = _search((0.4, 0.4, 0.2))
    fw = s.forward(base, band)
    steps = fw.steps
    assert sorted(st.name for st in steps) == sorted([A, B]) and steps[0].pair == steps[1].name
    first, partner = steps[0].name, steps[1].name
    assert abs(fw.fits[first].chi2_ - fw.fits[partner].chi2_) <= 2.0 * band.chi2_null_sd  # the tie the rule is about
    assert steps[0].ambiguous == [] and steps[1].ambiguous == []


@pytest.mark.parametrize("half_a, named", [(0.1, [A, B]), (5.0, [B])])
def test_an_addition_whose_size_holds_none_is_not_named(half_a, named):
    """a alone closes 29 % and b 26 % of the gap; a's bank is 2 -+ 5 sqrt(inflation) deg in the
    second case: a size the sampling cannot tell from none (what a non-linear
    candidate fitted to zero size on its own realisations looks like) is passed over at every
    step, and b is named alone. Before the rule a won the first step on a chi2 gain that was no
    effect's."""
    s, base, band, _ = _search((0.5, 0.45, 0.05), half={"road_bank": half_a})
    assert 0.1 * np.sqrt(band.inflation) < 2.0 < 5.0 * np.sqrt(band.inflation)  # the two cases' sizes, told from none or not
    fw = s.forward(base, band)
    assert [st.name for st in fw.steps] == named
    assert (A in fw.unresolved) == (half_a > 1) and ("holds 0" in fw.unresolved.get(A, "holds 0"))


def test_the_selection_stops_when_the_model_explains_the_data():
    """a is the whole gap: with it added the model is inside its band, and no further candidate
    is fitted on top of it (the budget of three effects is not spent on a model that explains)."""
    s, base, band, calls = _search((1.0, 0.0, 0.0))
    steps = s.forward(base, band).steps
    assert [st.name for st in steps] == [A] and steps[0].explains
    assert all(len(c) == 1 for c in calls)


def test_without_the_pair_step_two_small_halves_name_nothing(monkeypatch):
    """The same gap as the first case with no partner tried: the selection stops at the first
    effect that closes less than a quarter (the rule before pairs), and nothing is named."""
    monkeypatch.setattr(selection, "PAIR_PARTNERS", 0)
    s, base, band, _ = _search((0.42, 0.38, 0.2))
    assert s.forward(base, band).steps == ()


def test_a_partner_that_adds_nothing_on_top_is_not_named():
    """Each alone closes less than 25 %, but fitted together the partner saves nothing beyond the first:
    the pair is refused (a member must be justified on top of the other), nothing is named."""
    s, base, band, calls = _search((0.42, 0.38, 0.2), pair_joins=False)
    assert s.forward(base, band).steps == () and (A, B) in calls


@pytest.mark.parametrize("budget, named", [(1, []), (2, [A, B])])
def test_a_pair_needs_room_in_the_effect_budget(budget, named):
    """With one effect left in the budget no pair is tried; two suffice."""
    s, base, band, calls = _search((0.42, 0.38, 0.2))
    s.max_effects = budget
    fw = s.forward(base, band)
    assert [st.name for st in fw.steps] == named and any(len(c) == 2 for c in calls) == bool(named)
    assert fw.final is (fw.steps[-1].fit if named else base)


@pytest.mark.parametrize("pair_delay, named", [(0.004, []), (0.05, [A, "actuator_delay"])])
def test_a_pair_whose_fitted_size_is_unresolvable_is_refused(pair_delay, named):
    """The pair closes the gap, but in the pair's fit the partner's size falls below what the
    sampling resolves (a 4 ms dead time on a 10 ms grid): not named; at 50 ms it is."""
    s, base, band, calls = _search((0.42, 0.38, 0.2))
    s.candidates = [A, "actuator_delay"]
    joint = s.fitter.joint

    def delay_as_b(theta, names, values, max_nfev=None, release=(), **_):
        fit = joint(theta, [B if n == "actuator_delay" else n for n in names], values)
        fit.effect = EffectSet(list(names))
        fit.effect_values_ = np.array([pair_delay if n == "actuator_delay" and len(names) == 2 else (0.05 if n == "actuator_delay" else 1.0)
                                       for n in names])
        fit.effect_intervals = lambda factor=1.0: {p: [v, 0.9 * v, 1.1 * v] for p, v in zip(fit.effect.parameters, fit.effect_values_)}
        return fit

    s.fitter.joint = delay_as_b
    assert [st.name for st in s.forward(base, band).steps] == named and (A, B) in calls  # the pair was fitted (the delay standing in for b)


def _sized(names, half, chi2, cells=480):
    """A fit of ``names`` whose intervals are estimate -+ half sqrt(factor) (est: 2 deg bank, 0.1 rad/s bias)."""
    est = {A: ("road_bank.phi", 2.0), C: ("sensor_bias_psi_dot.offset_psi_dot", 0.1)}
    eff = EffectSet(names)
    intervals = lambda factor=1.0: {est[n][0]: [est[n][1], est[n][1] - half[n] * np.sqrt(factor), est[n][1] + half[n] * np.sqrt(factor)]  # noqa: E731
                                    for n in names}
    return SimpleNamespace(effect=eff, effect_values_=np.array([est[n][1] for n in names]), theta_=THETA, chi2_=chi2,
                           z_=np.zeros(cells), effect_intervals=intervals, scale_=np.ones(cells))


@pytest.mark.parametrize("inflation, chi2, kept", [(9.0, 480.0, [A]), (1.0, 480.0, [A, C]), (1.0, 480.0 * 9.0, [A, C])])
def test_an_effect_whose_interval_holds_no_effect_is_dropped(inflation, chi2, kept):
    """The bias (0.1 -+ 0.05 at unit inflation) is told from 0; at the null's inflation 9 its
    interval widens threefold to -+ 0.15, holds 0, and it is dropped, the rest refitted, and the
    bank (2 -+ 1.5) stays. The model's lack of fit does not enter: a rest nine times the null's
    misfit keeps the bias (the sampling decides whether a size is resolved; the chi2 tests
    whether the effect is needed)."""
    refits = []
    comparison, fitter = _linear(SimpleNamespace(inflation=inflation, mean_square_null=1.0),
                                 lambda theta, names, values, max_nfev=None, **_: refits.append(list(names)) or _sized(names, {A: 0.5}, chi2))
    base = SimpleNamespace(effect=None)
    out = selection.size_check(comparison, fitter, _steps(A, C), base, _sized([A, C], {A: 0.5, C: 0.05}, chi2), comparison.band, {})
    assert [s.name for s in out.steps] == kept
    assert [r["registry_name"] for r in out.removed] == ([C] if C not in kept else [])
    assert refits == ([[A]] if C not in kept else [])
    if C not in kept:
        assert "holds 0" in out.removed[0]["size"] and list(out.final.effect.names) == [A]


def test_a_single_effect_without_a_size_leaves_the_start_model():
    comparison, fitter = _linear(SimpleNamespace(inflation=9.0, mean_square_null=1.0), None)  # the null's inflation alone: -+ 0.15 holds 0
    base = SimpleNamespace(effect=None)
    out = selection.size_check(comparison, fitter, _steps(C), base, _sized([C], {C: 0.05}, 480.0), SimpleNamespace(mean_square_null=1.0), {})
    assert out.final is base and out.band is comparison.band and out.steps == () and out.removed[0]["registry_name"] == C


def _chi2_fit(names, chi2, values=None):
    eff = EffectSet(names) if names else None
    vals = np.asarray(values if values is not None else np.ones(len(eff.parameters) if eff else 0), float)
    return SimpleNamespace(effect=eff, effect_values_=vals, theta_=THETA, chi2_=chi2, z_=np.zeros(480), scale_=ONE)


def _steps(*names):
    return tuple(SimpleNamespace(name=n) for n in names)


def _linear(band, joint):
    """A comparison on the linear footing of 480 cells (chi2 the fits' own, every own band ``band``) and a fitter whose joint fits are ``joint``."""
    comparison = ModelComparison(band, ONE, bands=SimpleNamespace(null=lambda fit, key=0: band))
    fitter = CandidateFitter(SimpleNamespace(delta=np.zeros(100), dt=0.01, scale_for=lambda wide: ONE), {}, THETA, 0.97, top=3)
    fitter.joint = joint
    return comparison, fitter


def _backward(chi2_without, names=(A, C), fit=None):
    """The backward check of ``names`` at chi2 100, a refit without some costing ``chi2_without[rest]``."""
    band = SimpleNamespace(chi2_null_sd=5.0, inflation=1.0, mean_square_null=1.0)  # margin 10, penalty 2 per parameter
    comparison, fitter = _linear(SimpleNamespace(inflation=1.0, mean_square_null=1.0),
                                 lambda theta, rest, values, max_nfev=None, **_: _chi2_fit(list(rest), chi2_without[tuple(rest)]))
    return selection.backward_check(comparison, fitter, _steps(*names), fit or _chi2_fit(list(names), 100.0), band, {})


@pytest.mark.parametrize("without_c, dropped", [(105.0, [C]), (113.0, [])])
def test_the_backward_check_drops_an_effect_the_others_make_redundant(without_c, dropped):
    """Two effects at chi2 100; without the bias the refit costs 5 (< penalty 2 + margin 10: dropped)
    or 13 (> 12: kept); without the bank it costs 400 (kept). The saving is the refit's chi2 minus
    the full model's, not the other way round."""
    out = _backward({(C,): 500.0, (A,): without_c})
    assert [s.name for s in out.steps] == [n for n in (A, C) if n not in dropped]
    assert [r["registry_name"] for r in out.removed] == dropped
    if dropped:
        assert list(out.final.effect.names) == [A] and out.removed[0]["chi2_saved"] == pytest.approx(without_c - 100.0 - 2.0)


@pytest.mark.parametrize("without, dropped", [(113.0, ["lateral_load_transfer"]), (115.0, [])])
def test_the_backward_check_charges_the_penalty_per_parameter(without, dropped):
    """The lateral load transfer has two parameters (chi_f, p_Dz): its penalty is 4, so a refit
    without it costing 13 saves 9 (< margin 10: dropped) where a one-parameter effect's 11 would
    have kept it; 15 saves 11 (kept)."""
    L = "lateral_load_transfer"
    out = _backward({(L,): 500.0, (A,): without}, names=(A, L))
    assert [r["registry_name"] for r in out.removed] == dropped
    if dropped:
        assert out.removed[0]["chi2_saved"] == pytest.approx(without - 100.0 - 4.0)


def test_the_backward_check_keeps_a_single_effect():
    fit = _chi2_fit([A], 100.0)
    out = _backward({}, names=(A,), fit=fit)
    assert out.final is fit and out.removed == ()


@pytest.mark.parametrize("other, ambiguous", [(100.0 + 9.0, ["wind_gust"]), (100.0 + 11.0, [])])
def test_a_step_lists_candidates_within_the_margin_as_ambiguous(other, ambiguous):
    """The tie: another candidate's joint fit within the margin (10) of the named one's chi2."""
    comparison, _ = _linear(SimpleNamespace(inflation=1.0, mean_square_null=1.0), None)
    fits = {A: _chi2_fit([A], 100.0), B: _chi2_fit([B], other), C: _chi2_fit([C], 400.0)}
    step = selection._step(comparison, A, fits[A], None, "own", False, 0.5, fits, {A: {"chi2": 1.0, "held": 2.0, "anchor": "current"},
                                                                             B: {"chi2": np.inf, "held": 3.0, "anchor": "start"}}, 10.0)
    assert step.ambiguous == ambiguous
    assert list(step.candidates) == [A, B, C] and list(step.screening) == [A]  # an unranked (infinite) screening is left out


def test_an_unresolvable_size_that_explains_the_gap_ends_the_search():
    """The best fit is a dead time below one sample (4 ms on a 10 ms grid) that halves the gap:
    the gap is at the sampling's resolution, nothing is named and the reason is kept."""
    s, base, band, calls = _search((0.42, 0.38, 0.2))
    s.candidates = ["actuator_delay", B]
    joint = s.fitter.joint

    def with_delay(theta, names, values, max_nfev=None, release=(), **_):
        if "actuator_delay" in names:
            fit = joint(theta, [A, B], values)  # removes both parts: the gap more than halved
            fit.effect, fit.effect_values_ = EffectSet(["actuator_delay"]), np.array([0.004])
            fit.chi2_ = float(np.sum(fit.z_**2))
            return fit
        return joint(theta, names, values)

    s.fitter.joint = with_delay
    fw = s.forward(base, band)
    assert fw.final is base and fw.band is band
    assert fw.steps == () and fw.unresolved.get("explains_gap") == "actuator_delay"
    assert "below one sample" in fw.unresolved["actuator_delay"]


def test_of_two_effects_without_a_size_the_one_the_data_need_least_goes_first():
    """Both intervals hold no effect: the bank 2 -+ 2.5 (0.8 half-widths from 0), the bias 0.1 -+ 0.2
    (0.5). Refitted without the bank chi2 rises to 490, without the bias to 4800: the bank goes,
    and the bias refitted alone (0.1 -+ 0.05) has a size and stays. By the half-widths (the
    nearest to none first) the bias would have gone and the bank stayed."""
    comparison, fitter = _linear(SimpleNamespace(inflation=1.0, mean_square_null=1.0),
                                 lambda theta, names, values, max_nfev=None, **_: _sized(list(names), {A: 0.5, C: 0.05}, 490.0 if list(names) == [C] else 4800.0))
    out = selection.size_check(comparison, fitter, _steps(A, C), SimpleNamespace(effect=None), _sized([A, C], {A: 2.5, C: 0.2}, 480.0), comparison.band, {})
    assert [s.name for s in out.steps] == [C] and [r["registry_name"] for r in out.removed] == [A]
    assert list(out.final.effect.names) == [C] and out.final.chi2_ == 490.0


def _cancelling_search(together):
    """Stand-in fits of one gap: the compliance steer (linear) closes 1 - sqrt(0.75) = 13 % alone,
    the roll steer 5 %, the relaxation nothing (each alone bends to cancel the other), and the two
    non-linear ones together ``together`` of its excess mean square; every size told from none."""
    from uqdrive.vehicle.effects import EFFECTS

    rng = np.random.default_rng(3)
    (u, _, _), noise = _parts(rng)
    band = NullBand.from_replicates(0.3 * rng.standard_normal((300, 2, 4, K)), scan_windows(K))
    gap, one = 4.0 * u, np.ones_like(noise)
    R, S, CS = "roll_steer", "tyre_relaxation", "compliance_steer"

    def joint(theta, names, values, max_nfev=None, release=(), **_):
        s = set(names)
        left = 1.0 - together if {R, S} <= s else 0.75 if CS in s else 0.9 if R in s else 1.0
        calls.append((tuple(names), max_nfev, {k: list(values[k]) for k in names if k in values}))
        z = noise + np.sqrt(left) * gap
        eff = EffectSet(list(names))
        return SimpleNamespace(z_=z, chi2_=float(np.sum(z**2)), theta_=THETA, effect=eff, effect_values_=np.full(len(eff.parameters), 2.0),
                               structure_=ModelStructure(), scale_=one,
                               effect_intervals=lambda factor=1.0: {p: [2.0, 1.9, 2.1] for p in eff.parameters})

    calls = []
    search = _stand_in_search([CS, R, S], band, one, joint)
    search.fitter.probe = lambda theta, names, values, chi2, hopeless_above=None: joint(theta, names, values, max_nfev=6)
    base = SimpleNamespace(z_=noise + gap, chi2_=float(np.sum((noise + gap) ** 2)), theta_=THETA, effect=None, effect_values_=np.zeros(0),
                           structure_=ModelStructure(), scale_=one)
    return search, base, band, calls, EFFECTS


@pytest.mark.parametrize("together, pool, named", [(1.0, 4, ["roll_steer", "tyre_relaxation"]), (1.0, 0, []), (0.3, 4, [])])
def test_two_dynamic_effects_that_cancel_alone_are_added_together(monkeypatch, together, pool, named):
    """The compliance steer is the best addition but closes 13 % (less than a quarter) and has no
    partner (the lags alone save nothing on top of the baseline). The two non-linear candidates'
    pair, probed from the registry's starts (not from their bent single fits), then finished,
    explains the gap: both are named, the one with the better own fit first. Without the probes
    (pool 0) nothing is named; a pair that closes 1 - sqrt(0.7) = 16 % is not two additions' worth."""
    monkeypatch.setattr(selection, "PAIR_POOL", pool)
    s, base, band, calls, EFFECTS = _cancelling_search(together)
    steps = s.forward(base, band).steps
    assert [st.name for st in steps] == named
    probes = [c for c in calls if set(c[0]) == {"roll_steer", "tyre_relaxation"} and c[1] == selection.PAIR_PROBE_NFEV]
    assert len(probes) == (1 if pool else 0)
    if probes:  # from the registry's start values
        assert probes[0][2] == {k: list(EFFECTS[k].start) for k in ("roll_steer", "tyre_relaxation")}
    if named:
        assert steps[0].pair == "tyre_relaxation" and steps[1].pair == "roll_steer" and steps[1].explains

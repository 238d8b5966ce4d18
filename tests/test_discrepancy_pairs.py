"""Two rules of the forward selection, on stand-in fits: the pair step (two missing effects that
only together close their share of the gap; standardised gaps built from orthogonal parts, a's,
b's and an unexplained rest's share of the excess misfit chosen per case), and the size check
(a named effect's interval must not hold the value at which it vanishes)."""

from types import SimpleNamespace

import numpy as np
import pytest

from uqdrive.inference.discrepancy import DiscrepancyFinder, selection
from uqdrive.inference.discrepancy.band import NullBand, excess_rms, scan_windows
from uqdrive.inference.discrepancy.effectset import EffectSet
from uqdrive.vehicle.effects import ModelStructure
from uqdrive.settings import Settings

K = 60
THETA = np.array([1.0, 0.2, 1.55, 0.2, -400.0, 400.0])
A, B, C = "road_bank", "wind_gust", "sensor_bias_psi_dot"
ONE = np.ones(480)  # the scale of the stand-ins with 480 cells (all on the linear models' footing)


def _parts(rng):
    """Three orthonormal rough patterns (2, 4, K), unit mean square each, and a null-like noise."""
    q, _ = np.linalg.qr(rng.standard_normal((2 * 4 * K, 3)))
    return [v.reshape(2, 4, K) * np.sqrt(v.size) for v in q.T], 0.3 * rng.standard_normal((2, 4, K))


def _stand_in_finder(config, candidates, band, scale, joint):
    """A finder over ``candidates`` whose joint fits are ``joint``, chi2 the fits' own, every band
    ``band`` (no bootstrap), every candidate screened alike, on the linear footing (``scale``)."""
    f = DiscrepancyFinder(Settings.from_config(config), candidates=candidates, top=3, max_effects=3)
    f.candidates_, f.band_, f.scale_ = list(candidates), band, scale
    f.steps_, f.unresolved_, f.fits_, f.screening_, f.removed_ = [], {}, {}, {}, []
    f._joint, f._chi2 = joint, lambda fit: fit.chi2_
    f._own_band = lambda ctx, name, fit, band_, key=1: (band, "own")
    f._screen = lambda ctx, cur, pool: {c: {"chi2": 0.0, "held": 0.0, "theta": THETA, "values": [0.0], "anchor": "current"} for c in pool}
    return f


def _finder(config, shares, pair_joins=True, excess=16.0, half=None):
    """A finder whose joint fits are stand-ins: each candidate removes its own part of the gap
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

    def joint(ctx, theta, names, values, max_nfev=None):
        s = set(names)
        left = {"a", "b", "r"} - ({"a"} if A in s else set()) - ({"b"} if B in s and (pair_joins or A not in s) else set())
        calls.append(tuple(names))
        return fit(list(names), sorted(left))

    calls, one = [], np.ones_like(noise)
    f = _stand_in_finder(config, [A, B, C], band, one, joint)
    base = fit([], ["a", "b", "r"])
    ctx = SimpleNamespace(delta=np.zeros(100), dt=0.01)
    return f, base, band, ctx, calls


@pytest.mark.parametrize("shares, named", [
    ((0.42, 0.38, 0.2), [A, B]),     # alone a closes 1 - sqrt(0.58) = 24 %, b 21 % (< 25 %); together 1 - sqrt(0.2) = 55 % (>= 44 %)
    ((0.25, 0.25, 0.5), []),        # together 1 - sqrt(0.5) = 29 %: not two additions' worth
    ((0.5, 0.3, 0.2), [A, B]),       # a alone closes 29 %: named alone, then b on top of it (1 - sqrt(0.2 / 0.5) = 37 %)
])
def test_a_pair_is_named_when_it_closes_two_additions_worth(config, shares, named):
    f, base, band, ctx, calls = _finder(config, shares)
    gap0 = excess_rms(base.z_, band)
    f._forward(ctx, base, band, {}, lambda *a: None)
    assert [s["name"] for s in f.steps_] == named
    if named and shares[0] < 0.4375:  # the pair step: both recorded as a pair, the partner with the pair's fit
        assert f.steps_[0]["pair"] == B and f.steps_[1]["pair"] == A
        assert (A, B) in calls
        assert f.steps_[1]["gap_after"] <= selection.STEP_SHRINK**2 * gap0


def test_a_pair_member_is_not_ambiguous_with_its_partner(config):
    """a and b close 22.5 % each alone, within the margin of each other: the first member's own
    fit ties with its partner's, but both are named, so the partner is no alternative to it."""
    f, base, band, ctx, _ = _finder(config, (0.4, 0.4, 0.2))
    f._forward(ctx, base, band, {}, lambda *a: None)
    assert sorted(s["name"] for s in f.steps_) == sorted([A, B]) and f.steps_[0]["pair"] == f.steps_[1]["name"]
    first, partner = f.steps_[0]["name"], f.steps_[1]["name"]
    assert abs(f.fits_[first].chi2_ - f.fits_[partner].chi2_) <= 2.0 * band.chi2_null_sd  # the tie the rule is about
    assert f.steps_[0]["ambiguous"] == [] and f.steps_[1]["ambiguous"] == []


@pytest.mark.parametrize("half_a, named", [(0.1, [A, B]), (5.0, [B])])
def test_an_addition_whose_size_holds_none_is_not_named(config, half_a, named):
    """a alone closes 29 % and b 26 % of the gap; a's bank is 2 -+ 5 sqrt(inflation) deg in the
    second case: a size the sampling cannot tell from none (what a non-linear
    candidate fitted to zero size on its own realisations looks like) is passed over at every
    step, and b is named alone. Before the rule a won the first step on a chi2 gain that was no
    effect's."""
    f, base, band, ctx, _ = _finder(config, (0.5, 0.45, 0.05), half={"road_bank": half_a})
    assert 0.1 * np.sqrt(band.inflation) < 2.0 < 5.0 * np.sqrt(band.inflation)  # the two cases' sizes, told from none or not
    f._forward(ctx, base, band, {}, lambda *a: None)
    assert [s["name"] for s in f.steps_] == named
    assert (A in f.unresolved_) == (half_a > 1) and ("holds 0" in f.unresolved_.get(A, "holds 0"))


def test_the_selection_stops_when_the_model_explains_the_data(config):
    """a is the whole gap: with it added the model is inside its band, and no further candidate
    is fitted on top of it (the budget of three effects is not spent on a model that explains)."""
    f, base, band, ctx, calls = _finder(config, (1.0, 0.0, 0.0))
    f._forward(ctx, base, band, {}, lambda *a: None)
    assert [s["name"] for s in f.steps_] == [A] and f.steps_[0]["explains"]
    assert all(len(c) == 1 for c in calls)


def test_without_the_pair_step_two_small_halves_name_nothing(config, monkeypatch):
    """The same gap as the first case with no partner tried: the selection stops at the first
    effect that closes less than a quarter (the rule before pairs), and nothing is named."""
    monkeypatch.setattr(selection, "PAIR_PARTNERS", 0)
    f, base, band, ctx, _ = _finder(config, (0.42, 0.38, 0.2))
    f._forward(ctx, base, band, {}, lambda *a: None)
    assert f.steps_ == []


def test_a_partner_that_adds_nothing_on_top_is_not_named(config):
    """Each alone closes less than 25 %, but fitted together the partner saves nothing beyond the first:
    the pair is refused (a member must be justified on top of the other), nothing is named."""
    f, base, band, ctx, calls = _finder(config, (0.42, 0.38, 0.2), pair_joins=False)
    f._forward(ctx, base, band, {}, lambda *a: None)
    assert f.steps_ == [] and (A, B) in calls


@pytest.mark.parametrize("budget, named", [(1, []), (2, [A, B])])
def test_a_pair_needs_room_in_the_effect_budget(config, budget, named):
    """With one effect left in the budget no pair is tried; two suffice."""
    f, base, band, ctx, calls = _finder(config, (0.42, 0.38, 0.2))
    f.max_effects = budget
    final, _ = f._forward(ctx, base, band, {}, lambda *a: None)
    assert [s["name"] for s in f.steps_] == named and any(len(c) == 2 for c in calls) == bool(named)
    assert final is (f.steps_[-1]["fit"] if named else base)


@pytest.mark.parametrize("pair_delay, named", [(0.004, []), (0.05, [A, "actuator_delay"])])
def test_a_pair_whose_fitted_size_is_unresolvable_is_refused(config, pair_delay, named):
    """The pair closes the gap, but in the pair's fit the partner's size falls below what the
    sampling resolves (a 4 ms dead time on a 10 ms grid): not named; at 50 ms it is."""
    f, base, band, ctx, calls = _finder(config, (0.42, 0.38, 0.2))
    f.candidates_ = [A, "actuator_delay"]
    joint = f._joint

    def delay_as_b(ctx_, theta, names, values, max_nfev=None):
        fit = joint(ctx_, theta, [B if n == "actuator_delay" else n for n in names], values)
        fit.effect = EffectSet(list(names))
        fit.effect_values_ = np.array([pair_delay if n == "actuator_delay" and len(names) == 2 else (0.05 if n == "actuator_delay" else 1.0)
                                       for n in names])
        fit.effect_intervals = lambda factor=1.0: {p: [v, 0.9 * v, 1.1 * v] for p, v in zip(fit.effect.parameters, fit.effect_values_)}
        return fit

    f._joint = delay_as_b
    f._forward(ctx, base, band, {}, lambda *a: None)
    assert [s["name"] for s in f.steps_] == named and (A, B) in calls  # the pair was fitted (the delay standing in for b)


def _sized(names, half, chi2, cells=480):
    """A fit of ``names`` whose intervals are estimate -+ half sqrt(factor) (est: 2 deg bank, 0.1 rad/s bias)."""
    est = {A: ("road_bank.phi", 2.0), C: ("sensor_bias_psi_dot.offset_psi_dot", 0.1)}
    eff = EffectSet(names)
    intervals = lambda factor=1.0: {est[n][0]: [est[n][1], est[n][1] - half[n] * np.sqrt(factor), est[n][1] + half[n] * np.sqrt(factor)]  # noqa: E731
                                    for n in names}
    return SimpleNamespace(effect=eff, effect_values_=np.array([est[n][1] for n in names]), theta_=THETA, chi2_=chi2,
                           z_=np.zeros(cells), effect_intervals=intervals, scale_=np.ones(cells))


@pytest.mark.parametrize("inflation, chi2, kept", [(9.0, 480.0, [A]), (1.0, 480.0, [A, C]), (1.0, 480.0 * 9.0, [A, C])])
def test_an_effect_whose_interval_holds_no_effect_is_dropped(config, inflation, chi2, kept):
    """The bias (0.1 -+ 0.05 at unit inflation) is told from 0; at the null's inflation 9 its
    interval widens threefold to -+ 0.15, holds 0, and it is dropped, the rest refitted, and the
    bank (2 -+ 1.5) stays. The model's lack of fit does not enter: a rest nine times the null's
    misfit keeps the bias (the sampling decides whether a size is resolved; the chi2 tests
    whether the effect is needed)."""
    from uqdrive.inference.discrepancy.selection import size_check

    f = DiscrepancyFinder(Settings.from_config(config))
    f.band_ = SimpleNamespace(inflation=inflation, mean_square_null=1.0)
    f.scale_ = ONE
    f.steps_, f.removed_ = [{"name": A}, {"name": C}], []
    f._chi2 = lambda fit: fit.chi2_
    f._own_band = lambda ctx, name, fit, band, key=1: (band, "own")
    refits = []
    f._joint = lambda ctx, theta, names, values, max_nfev=None: refits.append(list(names)) or _sized(names, {A: 0.5}, chi2)
    base = SimpleNamespace(effect=None)
    final, _ = size_check(f, None, base, _sized([A, C], {A: 0.5, C: 0.05}, chi2), f.band_, {})
    assert [s["name"] for s in f.steps_] == kept
    assert [r["registry_name"] for r in f.removed_] == ([C] if C not in kept else [])
    assert refits == ([[A]] if C not in kept else [])
    if C not in kept:
        assert "holds 0" in f.removed_[0]["size"] and list(final.effect.names) == [A]


def test_a_single_effect_without_a_size_leaves_the_start_model(config):
    from uqdrive.inference.discrepancy.selection import size_check

    f = DiscrepancyFinder(Settings.from_config(config))
    f.band_ = SimpleNamespace(inflation=9.0, mean_square_null=1.0)  # the null's inflation alone: -+ 0.15 holds 0
    f.scale_ = ONE
    f.steps_, f.removed_ = [{"name": C}], []
    f._chi2 = lambda fit: fit.chi2_
    base = SimpleNamespace(effect=None)
    final, band = size_check(f, None, base, _sized([C], {C: 0.05}, 480.0), SimpleNamespace(mean_square_null=1.0), {})
    assert final is base and band is f.band_ and f.steps_ == [] and f.removed_[0]["registry_name"] == C


def _chi2_fit(names, chi2, values=None):
    eff = EffectSet(names) if names else None
    vals = np.asarray(values if values is not None else np.ones(len(eff.parameters) if eff else 0), float)
    return SimpleNamespace(effect=eff, effect_values_=vals, theta_=THETA, chi2_=chi2, z_=np.zeros(480), scale_=ONE)


def _backward_finder(config, chi2_without):
    from uqdrive.inference.discrepancy.selection import backward_check

    f = DiscrepancyFinder(Settings.from_config(config))
    f.band_ = SimpleNamespace(inflation=1.0, mean_square_null=1.0)
    f.scale_ = ONE
    band = SimpleNamespace(chi2_null_sd=5.0, inflation=1.0, mean_square_null=1.0)  # margin 10, penalty 2 per parameter
    f.steps_, f.removed_ = [{"name": A}, {"name": C}], []
    f._chi2 = lambda fit: fit.chi2_
    f._own_band = lambda ctx, name, fit, band, key=1: (band, "own")
    f._joint = lambda ctx, theta, names, values, max_nfev=None: _chi2_fit(list(names), chi2_without[tuple(names)])
    return f, band, backward_check


@pytest.mark.parametrize("without_c, dropped", [(105.0, [C]), (113.0, [])])
def test_the_backward_check_drops_an_effect_the_others_make_redundant(config, without_c, dropped):
    """Two effects at chi2 100; without the bias the refit costs 5 (< penalty 2 + margin 10: dropped)
    or 13 (> 12: kept); without the bank it costs 400 (kept). The saving is the refit's chi2 minus
    the full model's, not the other way round."""
    f, band, backward_check = _backward_finder(config, {(C,): 500.0, (A,): without_c})
    final, _ = backward_check(f, None, _chi2_fit([A, C], 100.0), band, {})
    assert [s["name"] for s in f.steps_] == [n for n in (A, C) if n not in dropped]
    assert [r["registry_name"] for r in f.removed_] == dropped
    if dropped:
        assert list(final.effect.names) == [A] and f.removed_[0]["chi2_saved"] == pytest.approx(without_c - 100.0 - 2.0)


@pytest.mark.parametrize("without, dropped", [(113.0, ["lateral_load_transfer"]), (115.0, [])])
def test_the_backward_check_charges_the_penalty_per_parameter(config, without, dropped):
    """The lateral load transfer has two parameters (chi_f, p_Dz): its penalty is 4, so a refit
    without it costing 13 saves 9 (< margin 10: dropped) where a one-parameter effect's 11 would
    have kept it; 15 saves 11 (kept)."""
    L = "lateral_load_transfer"
    f, band, backward_check = _backward_finder(config, {(L,): 500.0, (A,): without})
    f.steps_ = [{"name": A}, {"name": L}]
    backward_check(f, None, _chi2_fit([A, L], 100.0), band, {})
    assert [r["registry_name"] for r in f.removed_] == dropped
    if dropped:
        assert f.removed_[0]["chi2_saved"] == pytest.approx(without - 100.0 - 4.0)


def test_the_backward_check_keeps_a_single_effect(config):
    f, band, backward_check = _backward_finder(config, {})
    f.steps_ = [{"name": A}]
    fit = _chi2_fit([A], 100.0)
    assert backward_check(f, None, fit, band, {})[0] is fit and f.removed_ == []


@pytest.mark.parametrize("other, ambiguous", [(100.0 + 9.0, ["wind_gust"]), (100.0 + 11.0, [])])
def test_a_step_lists_candidates_within_the_margin_as_ambiguous(config, other, ambiguous):
    """The tie: another candidate's joint fit within the margin (10) of the named one's chi2."""
    f = DiscrepancyFinder(Settings.from_config(config))
    f._chi2 = lambda fit: fit.chi2_
    fits = {A: _chi2_fit([A], 100.0), B: _chi2_fit([B], other), C: _chi2_fit([C], 400.0)}
    step = selection._step(f, A, fits[A], None, "own", False, 0.5, fits, {A: {"chi2": 1.0, "held": 2.0, "anchor": "current"},
                                                                    B: {"chi2": np.inf, "held": 3.0, "anchor": "start"}}, 10.0)
    assert step["ambiguous"] == ambiguous
    assert list(step["candidates"]) == [A, B, C] and list(step["screening"]) == [A]  # an unranked (infinite) screening is left out


def test_an_unresolvable_size_that_explains_the_gap_ends_the_search(config):
    """The best fit is a dead time below one sample (4 ms on a 10 ms grid) that halves the gap:
    the gap is at the sampling's resolution, nothing is named and the reason is kept."""
    f, base, band, ctx, calls = _finder(config, (0.42, 0.38, 0.2))
    f.candidates_ = ["actuator_delay", B]
    joint = f._joint

    def with_delay(ctx_, theta, names, values, max_nfev=None):
        if "actuator_delay" in names:
            fit = joint(ctx_, theta, [A, B], values)  # removes both parts: the gap more than halved
            fit.effect, fit.effect_values_ = EffectSet(["actuator_delay"]), np.array([0.004])
            fit.chi2_ = float(np.sum(fit.z_**2))
            return fit
        return joint(ctx_, theta, names, values)

    f._joint = with_delay
    final, final_band = f._forward(ctx, base, band, {}, lambda *a: None)
    assert final is base and final_band is band
    assert f.steps_ == [] and f.unresolved_.get("explains_gap") == "actuator_delay"
    assert "below one sample" in f.unresolved_["actuator_delay"]


def test_of_two_effects_without_a_size_the_one_the_data_need_least_goes_first(config):
    """Both intervals hold no effect: the bank 2 -+ 2.5 (0.8 half-widths from 0), the bias 0.1 -+ 0.2
    (0.5). Refitted without the bank chi2 rises to 490, without the bias to 4800: the bank goes,
    and the bias refitted alone (0.1 -+ 0.05) has a size and stays. By the half-widths (the
    nearest to none first) the bias would have gone and the bank stayed."""
    from uqdrive.inference.discrepancy.selection import size_check

    f = DiscrepancyFinder(Settings.from_config(config))
    f.band_ = SimpleNamespace(inflation=1.0, mean_square_null=1.0)
    f.scale_ = ONE
    f.steps_, f.removed_ = [{"name": A}, {"name": C}], []
    f._chi2 = lambda fit: fit.chi2_
    f._own_band = lambda ctx, name, fit, band, key=1: (band, "own")
    f._joint = lambda ctx, theta, names, values, max_nfev=None: _sized(list(names), {A: 0.5, C: 0.05}, 490.0 if list(names) == [C] else 4800.0)
    final, _ = size_check(f, None, SimpleNamespace(effect=None), _sized([A, C], {A: 2.5, C: 0.2}, 480.0), f.band_, {})
    assert [s["name"] for s in f.steps_] == [C] and [r["registry_name"] for r in f.removed_] == [A]
    assert list(final.effect.names) == [C] and final.chi2_ == 490.0


def _cancelling_finder(config, together):
    """Stand-in fits of one gap: the compliance steer (linear) closes 1 - sqrt(0.75) = 13 % alone,
    the roll steer 5 %, the relaxation nothing (each alone bends to cancel the other), and the two
    non-linear ones together ``together`` of its excess mean square; every size told from none."""
    from uqdrive.vehicle.effects import EFFECTS

    rng = np.random.default_rng(3)
    (u, _, _), noise = _parts(rng)
    band = NullBand.from_replicates(0.3 * rng.standard_normal((300, 2, 4, K)), scan_windows(K))
    gap, one = 4.0 * u, np.ones_like(noise)
    R, S, CS = "roll_steer", "tyre_relaxation", "compliance_steer"

    def joint(ctx, theta, names, values, max_nfev=None):
        s = set(names)
        left = 1.0 - together if {R, S} <= s else 0.75 if CS in s else 0.9 if R in s else 1.0
        calls.append((tuple(names), max_nfev, {k: list(values[k]) for k in names if k in values}))
        z = noise + np.sqrt(left) * gap
        eff = EffectSet(list(names))
        return SimpleNamespace(z_=z, chi2_=float(np.sum(z**2)), theta_=THETA, effect=eff, effect_values_=np.full(len(eff.parameters), 2.0),
                               structure_=ModelStructure(), scale_=one,
                               effect_intervals=lambda factor=1.0: {p: [2.0, 1.9, 2.1] for p in eff.parameters})

    calls = []
    f = _stand_in_finder(config, [CS, R, S], band, one, joint)
    f._probe = lambda ctx, theta, names, values: joint(ctx, theta, names, values, max_nfev=6)
    base = SimpleNamespace(z_=noise + gap, chi2_=float(np.sum((noise + gap) ** 2)), theta_=THETA, effect=None, effect_values_=np.zeros(0),
                           structure_=ModelStructure(), scale_=one)
    return f, base, band, SimpleNamespace(delta=np.zeros(100), dt=0.01), calls, EFFECTS


@pytest.mark.parametrize("together, pool, named", [(1.0, 4, ["roll_steer", "tyre_relaxation"]), (1.0, 0, []), (0.3, 4, [])])
def test_two_dynamic_effects_that_cancel_alone_are_added_together(config, monkeypatch, together, pool, named):
    """The compliance steer is the best addition but closes 13 % (less than a quarter) and has no
    partner (the lags alone save nothing on top of the baseline). The two non-linear candidates'
    pair, probed from the registry's starts (not from their bent single fits), then finished,
    explains the gap: both are named, the one with the better own fit first. Without the probes
    (pool 0) nothing is named; a pair that closes 1 - sqrt(0.7) = 16 % is not two additions' worth."""
    monkeypatch.setattr(selection, "PAIR_POOL", pool)
    f, base, band, ctx, calls, EFFECTS = _cancelling_finder(config, together)
    f._forward(ctx, base, band, {}, lambda *a: None)
    assert [s["name"] for s in f.steps_] == named
    probes = [c for c in calls if set(c[0]) == {"roll_steer", "tyre_relaxation"} and c[1] == selection.PAIR_PROBE_NFEV]
    assert len(probes) == (1 if pool else 0)
    if probes:  # from the registry's start values
        assert probes[0][2] == {k: list(EFFECTS[k].start) for k in ("roll_steer", "tyre_relaxation")}
    if named:
        assert f.steps_[0]["pair"] == "tyre_relaxation" and f.steps_[1]["pair"] == "roll_steer" and f.steps_[1]["explains"]

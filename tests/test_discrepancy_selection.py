"""Several effects in one verdict: the effect set fitted as one, forward selection with joint
refits and a backward check, the combined benchmark's scoring, and `discover --model`."""

import copy
import json
from types import SimpleNamespace

import numpy as np
import pytest
import yaml

import uqdrive
from uqdrive.cli import main
from uqdrive.inference.discrepancy.band import NullBand
from uqdrive.inference.discrepancy.comparison import Compared, ModelComparison
from uqdrive.inference.discrepancy.fitter import CandidateFitter, in_reach
from uqdrive.inference.discrepancy.effectset import EffectSet, family_of
from uqdrive.io import write_dataset
from uqdrive.studies.discrepancy import benchmark_dataset, case_outcome, exact_set
from uqdrive.studies.hidden_effects import HiddenEffectCase, case_label, generate, simulate_states
from uqdrive.vehicle.effects import EFFECTS, ModelStructure
from uqdrive.settings import Settings


def test_effect_set_chains_its_members_in_order():
    """Parameters concatenated as effect.parameter, each member applied with its own values, the
    provenance in the order added; an effect twice or wrong sizes are refused."""
    es = EffectSet(["road_bank", "sensor_bias_psi_dot", "actuator_lag"], start={"actuator_lag": [0.2]})
    assert es.parameters == ("road_bank.phi", "sensor_bias_psi_dot.offset_psi_dot", "actuator_lag.T")
    assert es.start == (0.0, 0.0, 0.2) and len(es.bounds) == 3
    s = es.augment(ModelStructure(), [2.0, 0.01, 0.1])
    assert s.lateral_acceleration == pytest.approx(9.81 * np.sin(np.deg2rad(2.0)))
    assert s.output_offset[1] == 0.01 and s.steering_lag == 0.1
    assert [name for name, _ in s.effects] == list(es.names)
    assert {k: list(v) for k, v in es.split([2.0, 0.01, 0.1]).items()} == {"road_bank": [2.0], "sensor_bias_psi_dot": [0.01], "actuator_lag": [0.1]}
    assert es.intervals({"road_bank.phi": [2, 1, 3], "actuator_lag.T": [0.1, 0.0, 0.2]})["road_bank"] == {"phi": [2.0, 1.0, 3.0]}
    with pytest.raises(ValueError, match="at most once"):
        EffectSet(["road_bank", "road_bank"])
    with pytest.raises(ValueError, match="parameter"):
        es.augment(ModelStructure(), [1.0])
    assert family_of("sensor_bias_y") == "sensor_bias" and family_of("road_bank") == "road_bank"


def test_exact_set_counts_ambiguity_sets_and_refuses_extras():
    lag, bank = {"effect": "actuator_lag", "ambiguous_with": ["actuator_delay"]}, {"effect": "road_bank", "ambiguous_with": []}
    assert exact_set(["road_bank", "actuator_lag"], [lag, bank])  # order free
    assert exact_set(["actuator_delay", "road_bank"], [lag, bank])  # the truth in an ambiguity set counts
    assert not exact_set(["road_bank"], [lag, bank])  # one too many
    assert not exact_set(["road_bank", "actuator_lag"], [bank])  # one missing
    rest = {"effect": "unrecognised", "ambiguous_with": []}
    assert not exact_set(["road_bank", "actuator_lag"], [bank, rest])  # a rest stands in for no effect
    assert exact_set(["road_bank", "actuator_lag"], [bank, lag, rest])  # nor counts against the set
    assert not exact_set(["road_bank"], [lag, rest])
    assert not exact_set(["actuator_lag", "road_bank"], [lag, lag])  # each truth needs its own entry


def test_combined_outcomes_and_their_confusion_table():
    label = {"name": "c", "effect": "road_bank", "effects": [{"effect": "road_bank"}, {"effect": "sensor_bias"}], "magnitude": 2.0}
    verdict = {"effect": "sensor_bias", "gap_before": 10.0, "gap_after": 0.5, "ambiguous_with": [],
               "effects": [{"effect": "sensor_bias", "gap_after": 6.0}, {"effect": "road_bank", "gap_after": 0.5}],
               "distributions": {"before": {"mu": {"mean": 1.0}}, "after": {"mu": {"mean": 1.0}}}}
    o = case_outcome(label, verdict)
    assert o["combined"] and o["correct"] and o["gap_halved"] and o["gap_steps"] == "10;6;0.5"
    assert o["truth_set"] == o["named_set"] == "road_bank+sensor_bias" and not o["rest_unexplained"]
    rest = case_outcome(label, dict(verdict, effects=verdict["effects"] + [{"effect": "unrecognised", "gap_after": 0.5}]))
    assert rest["correct"] and rest["rest_unexplained"] and rest["gap_steps"] == "10;6;0.5"
    wrong = dict(verdict, effects=verdict["effects"][:1])
    null = case_outcome({"name": "n", "effect": "none"}, {**verdict, "effect": "none", "effects": []})
    ds = benchmark_dataset([o, case_outcome(dict(label, name="d"), wrong), null])
    assert ds.attrs["combined_accuracy"] == 0.5 and ds.attrs["n_combined"] == 2
    assert int(ds["confusion_combined"].sel(true_set="road_bank+sensor_bias", named_set_column="sensor_bias")) == 1


def test_effective_chi2_puts_a_non_linear_fit_on_the_linear_footing():
    """A model on fewer realisations is judged with a wider scale; its excess chi2 is scaled back
    by the squared ratio, so a non-linear fit that changes nothing is no better than the linear.
    The ratio is the one of the scale the fit was judged with: a non-linear candidate fitted to
    zero size has a linear structure, and its chi2 on the wide scale is not the linear one's. The
    excess counts from the non-linear footing's own null level, and a comparison with a fit on
    that footing has its margin."""
    data = Compared(None, None, None, None, None, 1000, None, 0.01, None, np.ones((2, 4, 10)), model_samples=1000, nonlinear_samples=250)
    f = ModelComparison(SimpleNamespace(mean_square_null=1.0), data.scale)
    z = np.zeros((2, 4, 10))  # 80 cells: the null level is 80
    ratio = (1 + 1000 / 250) / (1 + 1000 / 1000)  # scale ratio squared (Compared.scale_for)
    wide_scale = data.scale_for(True)
    assert np.mean((wide_scale / f.scale) ** 2) == pytest.approx(ratio, rel=1e-12)
    assert data.scale_for(False) is data.scale
    # the same systematic misfit (640) plus each model's own sampling (80 in its own units)
    linear = SimpleNamespace(structure_=ModelStructure(), z_=z, chi2_=80.0 + 640.0, scale_=f.scale)
    wide = SimpleNamespace(structure_=EFFECTS["tyre_saturation"].augment(ModelStructure(), [0.5]), z_=z, chi2_=80.0 + 640.0 / ratio, scale_=wide_scale)
    assert f.chi2(linear) == pytest.approx(720.0)
    assert f.chi2(wide) == pytest.approx(720.0)
    assert wide.chi2_ < f.chi2(wide)  # the raw chi2 would have favoured it
    # a load transfer fitted to h = 0: its structure is the linear model's, its z on the wide scale
    zero = SimpleNamespace(structure_=EFFECTS["longitudinal_load_transfer"].augment(ModelStructure(), [0.0]), z_=z, chi2_=wide.chi2_, scale_=wide_scale)
    assert not zero.structure_.nonlinear
    assert f.chi2(zero) == pytest.approx(720.0)  # by its structure it would score 336 and beat the linear model
    # below the null level nothing systematic is left to convert: the sampling luck is not multiplied
    lucky = SimpleNamespace(structure_=wide.structure_, z_=z, chi2_=60.0, scale_=wide_scale)
    assert f.chi2(lucky) == pytest.approx(60.0)  # scaled it would be 80 - 20 x 2.5 = 30
    # with the non-linear footing's own band (its few raw realisations' luck: level 1.5 per cell)
    # the excess is counted from that level: a fit at it is at the linear null level
    f = ModelComparison(SimpleNamespace(mean_square_null=1.0, chi2_null_sd=10.0), data.scale,
                        footing_band=SimpleNamespace(mean_square_null=1.5, chi2_null_sd=30.0))
    at_level = SimpleNamespace(structure_=wide.structure_, z_=z, chi2_=120.0, scale_=wide_scale)
    assert f.chi2(at_level) == pytest.approx(80.0)
    assert f.chi2(SimpleNamespace(**{**vars(at_level), "chi2_": 120.0 + 256.0})) == pytest.approx(80.0 + 256.0 * ratio)
    assert f.chi2(linear) == pytest.approx(720.0)  # a linear fit keeps its chi2
    # a comparison with a fit on the wide footing: the margin is that footing's chi2 spread, converted
    assert f.margin(20.0, linear, wide) == pytest.approx(2.0 * ratio * 30.0)
    assert f.margin(20.0, wide, zero) == pytest.approx(2.0 * ratio * 30.0)
    assert f.margin(20.0, linear, linear) == 20.0 and f.margin(500.0, linear, wide) == 500.0


def test_gate_needs_a_scan_crossing_and_an_excess_misfit():
    """``gate``: the scan maximum beyond the threshold AND chi2 beyond the null mean by 2 sd; its
    false-alarm rate is counted on the replicates themselves."""
    rng = np.random.default_rng(0)
    z = rng.standard_normal((200, 2, 4, 30))
    band = NullBand.from_replicates(z, np.array([[0, 1], [0, 30]]), level=0.05)
    spike = np.zeros((2, 4, 30))
    spike[0, 0, 0] = 10 * band.cell_scale[0, 0, 0]  # one crossing, total misfit tiny
    assert band.max_statistic(spike) > band.threshold and not band.gate(spike)
    broad = rng.standard_normal((2, 4, 30)) * 3.0
    assert band.gate(broad)
    assert 0.0 <= band.false_alarm_rate() <= 0.05


def test_combined_reality_adds_each_effect_as_alone(config):
    """The combined reality's bank + bias equals the bank's reality with the bias on psi_dot; a
    course angle with a non-linear tyre integrates v sin(psi + beta)."""
    c = copy.deepcopy(config)
    c["time"].update(t_end=2.0)
    both = HiddenEffectCase("b", "road_bank", 2.0, "chirp", {"amplitude_deg": 2.0}, samples=4, seed=3, extra=[("sensor_bias", 0.01, "psi_dot")])
    bank = HiddenEffectCase("b", "road_bank", 2.0, "chirp", {"amplitude_deg": 2.0}, samples=4, seed=3)
    a, b = generate(c, both), generate(c, bank)
    assert np.allclose(a["psi_dot"].values - b["psi_dot"].values, 0.01) and np.array_equal(a["y"].values, b["y"].values)
    sat = HiddenEffectCase("s", "tyre_saturation", 5.0, "slalom", {"period": 3.0}, samples=3, seed=4)
    course = HiddenEffectCase("s", "tyre_saturation", 5.0, "slalom", {"period": 3.0}, samples=3, seed=4, extra=[("lateral_kinematics", 5.0, None)])
    _, _, xs = simulate_states(c, sat)
    _, _, xc = simulate_states(c, course)
    assert np.array_equal(xs[:3], xc[:3]) and np.abs(xs[3] - xc[3]).max() > 0.01
    assert case_label(both)["effects"] == [{"effect": "road_bank", "magnitude": 2.0, "channel": None},
                                           {"effect": "sensor_bias", "magnitude": 0.01, "channel": "psi_dot"}]
    with pytest.raises(ValueError, match="distinct"):
        HiddenEffectCase("x", "road_bank", 1.0, "step", extra=[("road_bank", 2.0, None)])
    with pytest.raises(ValueError, match="primary"):
        HiddenEffectCase("x", "none", 0.0, "step", extra=[("road_bank", 2.0, None)])


@pytest.fixture(scope="module")
def combined(config, tmp_path_factory):
    """Bank 2 deg and a psi_dot bias of 0.01 rad/s at once on a chirp, 300 realisations."""
    c = copy.deepcopy(config)
    c["time"].update(t_end=6.0)
    c["discrepancy"].update(model_samples=300, nonlinear_samples=100, bootstrap=40, max_times=60, top=2)
    root = tmp_path_factory.mktemp("combined")
    (root / "config.yaml").write_text(yaml.safe_dump(c))
    case = HiddenEffectCase("bank_bias", "road_bank", 2.0, "chirp", {"amplitude_deg": 2.0}, samples=300, seed=21, extra=[("sensor_bias", 0.01, "psi_dot")])
    write_dataset(generate(c, case), root / "data.nc")
    return root


@pytest.mark.long(40)
def test_two_hidden_effects_are_both_named_and_the_model_continues(combined, capsys):
    """Both effects named (order free) with intervals holding the truth, the gap shrinking at each
    addition and closing at least by half; model.yaml holds both; `discover --model` from a model
    with the bank alone adds the bias only; `identify --model` takes both effects."""
    cfg, data = str(combined / "config.yaml"), str(combined / "data.nc")
    cands = "road_bank,sensor_bias,actuator_lag"
    assert main(["discover", data, "--config", cfg, "--candidates", cands, "--out", str(combined / "out")]) == 0
    v = json.loads((combined / "out" / "verdict.json").read_text())
    named = {e["effect"]: e for e in v["effects"]}
    assert set(named) == {"road_bank", "sensor_bias"} and v["effect"] == v["effects"][0]["effect"]
    est, lo, hi = named["road_bank"]["parameters"]["phi"]
    assert lo <= 2.0 <= hi
    est, lo, hi = named["sensor_bias"]["parameters"]["offset_psi_dot"]
    assert lo <= 0.01 <= hi and named["sensor_bias"]["parameters"]["channel"] == "psi_dot"
    gaps = [v["gap_before"]] + [e["gap_after"] for e in v["effects"]]
    assert all(b < a for a, b in zip(gaps, gaps[1:])) and v["gap_after"] <= 0.5 * v["gap_before"] and v["gap_after"] == gaps[-1]
    model = yaml.safe_load((combined / "out" / "model.yaml").read_text())
    assert set(model["effects"]) == {"road_bank", "sensor_bias_psi_dot"}
    start = copy.deepcopy(model)
    del start["effects"]["sensor_bias_psi_dot"]
    (combined / "bank.yaml").write_text(yaml.safe_dump(start))
    assert main(["discover", data, "--config", cfg, "--candidates", cands, "--model", str(combined / "bank.yaml"), "--out", str(combined / "more")]) == 0
    w = json.loads((combined / "more" / "verdict.json").read_text())
    assert [e["effect"] for e in w["effects"]] == ["sensor_bias"] and w["evidence"]["start_model"] == ["road_bank"]
    assert main(["identify", data, "--model", str(combined / "out" / "model.yaml"), "--config", cfg, "--out", str(combined / "ident")]) == 0
    e = json.loads((combined / "ident" / "estimate.json").read_text())
    assert set(e["effects"]) == {"road_bank", "sensor_bias_psi_dot"}
    capsys.readouterr()


def test_a_non_linear_probe_is_finished_when_in_reach():
    """The short fit of a non-linear candidate is continued when it closed a quarter of what the
    best linear candidate closed, or when no linear candidate closed anything; else dropped."""
    f = ModelComparison(SimpleNamespace(mean_square_null=1.0), np.ones((2, 4, 10)))
    fit = lambda chi2: SimpleNamespace(structure_=ModelStructure(), z_=np.zeros((2, 4, 10)), chi2_=chi2, scale_=f.scale)  # noqa: E731
    cur, best_linear = fit(1000.0), fit(200.0)  # the linear candidate closes 800
    assert in_reach(f, cur, fit(790.0), [best_linear])  # 210 >= 0.25 x 800
    assert not in_reach(f, cur, fit(810.0), [best_linear])  # 190 < 200
    assert in_reach(f, cur, fit(1000.0), [fit(1100.0)]) and in_reach(f, cur, fit(1000.0), [])


def test_combined_figures_draw_one_line_per_case_and_a_note_without_cases():
    import matplotlib.pyplot as plt

    from uqdrive.plots.discrepancy import combined_confusion, gap_per_effect

    label = {"name": "c", "effect": "road_bank", "effects": [{"effect": "road_bank"}, {"effect": "sensor_bias"}], "magnitude": 2.0}
    verdict = {"effect": "sensor_bias", "gap_before": 10.0, "gap_after": 0.5, "ambiguous_with": [],
               "effects": [{"effect": "sensor_bias", "gap_after": 6.0}, {"effect": "road_bank", "gap_after": 0.5}],
               "distributions": {"before": {"mu": {"mean": 1.0}}, "after": {"mu": {"mean": 1.0}}}}
    null = case_outcome({"name": "n", "effect": "none"}, {**verdict, "effect": "none", "effects": [], "gap_after": 10.0})
    ds = benchmark_dataset([case_outcome(label, verdict), case_outcome(dict(label, name="d"), verdict), null])
    fig = gap_per_effect(ds)
    assert [list(line.get_ydata()) for line in fig.axes[0].lines] == [[10.0, 6.0, 0.5]] * 2
    fig2 = combined_confusion(ds)
    assert fig2.axes[0].images[0].get_array().sum() == 2
    without = benchmark_dataset([null])
    assert "no combined" in combined_confusion(without).axes[0].texts[0].get_text()
    assert "no combined" in gap_per_effect(without).axes[0].texts[0].get_text()
    plt.close("all")


def test_a_non_linear_probe_starts_from_the_current_and_the_prior_distributions(config):
    """The short fit is run from the current distributions and from the prior's and the better
    one kept: from a linear baseline's lowered mu a saturating tyre sits in a poor basin (the
    thesis' NLST data: chi2 5 times the baseline's), from the prior it reaches the truth."""
    prior = list(Settings.from_config(config).layout.start)
    f = CandidateFitter(None, {}, prior, 0.97, top=3)
    chi2 = ModelComparison(SimpleNamespace(mean_square_null=1.0), np.ones((2, 4, 10))).chi2
    starts = []

    def joint(theta, names, values, max_nfev=None, **_):
        starts.append((list(theta), max_nfev))
        chi2 = 50.0 if list(theta) == list(prior) else 900.0  # only the prior's start reaches the good basin
        return SimpleNamespace(structure_=ModelStructure(), z_=np.zeros((2, 4, 10)), chi2_=chi2, theta_=theta, scale_=np.ones((2, 4, 10)))

    f.joint = joint
    lowered = [0.84] + list(prior[1:])
    best = f.probe(lowered, ["tyre_saturation"], {"tyre_saturation": [0.5]}, chi2)
    assert best.chi2_ == 50.0 and list(best.theta_) == list(prior)
    assert starts == [(lowered, 6), (list(prior), 6)]  # both starts, each with the probe's budget
    starts.clear()
    joint_lowered_wins = lambda theta, names, values, max_nfev=None, **_: SimpleNamespace(  # noqa: E731
        structure_=ModelStructure(), z_=np.zeros((2, 4, 10)), chi2_=10.0 if list(theta) == lowered else 900.0, theta_=theta, scale_=np.ones((2, 4, 10)))
    f.joint = joint_lowered_wins
    assert list(f.probe(lowered, ["tyre_saturation"], {}, chi2).theta_) == lowered


def test_of_candidates_tied_with_the_best_the_one_with_fewest_parameters_leads():
    """tyre_shape (3 parameters) fits 2 better than tyre_saturation (1): within a margin of 5
    the data cannot tell them apart and the special case leads; outside it the better fit does."""
    from uqdrive.inference.discrepancy.selection import simplest_first

    fits = {"tyre_shape": 100.0, "tyre_saturation": 102.0, "road_bank": 150.0}
    chi2 = lambda f: f  # noqa: E731
    assert simplest_first(fits, chi2, 5.0) == ["tyre_saturation", "tyre_shape", "road_bank"]
    assert simplest_first(fits, chi2, 1.0) == ["tyre_shape", "tyre_saturation", "road_bank"]
    assert simplest_first({}, chi2, 1.0) == []


@pytest.mark.long(20)
@pytest.mark.filterwarnings("ignore:os.fork\\(\\) was called:RuntimeWarning")  # JAX of another test in this process (tests/test_parallel.py)
def test_worker_processes_give_the_verdict_of_one_process(combined):
    """jobs=2 (the screening's held fits, each step's candidate fits and probes, the backward
    check's refits on two forked workers) gives verdict.json of jobs=1 number for number, timings
    aside; the workers did the fits (the children's CPU grew), and a fit made in a worker holds
    the parent's simulator and memo, not copies."""
    import resource

    cands = ["road_bank", "sensor_bias_psi_dot", "actuator_lag", "tyre_saturation"]
    cfg = yaml.safe_load((combined / "config.yaml").read_text())

    def run(jobs):
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        v = uqdrive.discover(combined / "data.nc", config=cfg, candidates=cands, posterior=False, jobs=jobs)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        doc = v.to_dict()
        for key in ("seconds", "stage_seconds"):
            doc["evidence"].pop(key)
        return v, doc, (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)

    one, alone, _ = run(1)
    two, shared, children = run(2)
    assert {e["effect"] for e in alone["effects"]} == {"road_bank", "sensor_bias"}  # two steps: the backward check refits
    assert shared == alone
    assert children > 1.0, children
    f = two.finder
    fits = [s.fit for s in f.steps_] + list(f.fits_.values())
    d = f.fitter_.data
    assert all(any(fit.simulator is s for s in (d.sim, d.sim_for(True))) for fit in fits)
    assert all(fit.memo is f.baseline_.memo for fit in fits) and f.baseline_.memo is not None

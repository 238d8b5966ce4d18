"""Known quantities (std 0, low == high): accepted by the config, the chaos model, simulate and
identify, left out of the identified vector and reported as fixed."""

import copy
import json

import numpy as np
import pytest
import yaml

from uqdrive.cli.main import main
from uqdrive.config import ConfigError, validate_config
from uqdrive.vehicle.chaos import LSTChaosModel
from uqdrive.vehicle.montecarlo import simulate_ensemble

from conftest import REPO
from uqdrive.settings import Settings


def _coarse(l_f_std=0.2, wind=None, dt=0.05):
    """The test config on a coarse grid (the fit's cost ~ T), with l_f's std and the mean wind given."""
    cfg = yaml.safe_load((REPO / "config" / "test.yaml").read_text())
    cfg["time"].update(dt=dt, step=dt / 2)
    cfg["uncertainty"]["l_f"]["std"] = l_f_std
    if wind is not None:
        cfg["uncertainty"]["F_w_mean"] = wind
    return cfg


def test_config_accepts_known_quantities_and_still_refuses_negative_spreads(cfg):
    for key in ("mu", "m_load", "l_f"):
        c = copy.deepcopy(cfg)
        c["uncertainty"][key]["std"] = 0.0
        validate_config(c)
        assert Settings.from_config(c).uncertainty.known() == {key: c["uncertainty"][key]["mean"]}
    c = copy.deepcopy(cfg)
    c["uncertainty"]["F_w_mean"] = {"low": 120.0, "high": 120.0}
    validate_config(c)
    assert Settings.from_config(c).uncertainty.known() == {"F_w_mean": 120.0}
    assert Settings.from_config(cfg).uncertainty.known() == {}  # today's config: nothing known, every germ as before
    c["uncertainty"]["l_f"]["std"] = -0.01
    with pytest.raises(ConfigError, match="uncertainty.l_f.std"):
        validate_config(c)


def test_chaos_model_drops_the_germ_of_a_known_quantity(config):
    """A known l_f: no germ, no theta entries, and moments equal to the model with l_f fixed
    at that value explicitly (same numbers: the two are the same model)."""
    c = copy.deepcopy(config)
    c["time"].update(t_end=2.0, dt=0.05, step=0.025)
    ref = LSTChaosModel(Settings.from_config(c), uncertain=("mu", "F_w_mean"), time_variant_wind=False)
    c["uncertainty"]["l_f"]["std"] = 0.0
    model = LSTChaosModel(Settings.from_config(c), uncertain=("mu", "l_f", "F_w_mean"), time_variant_wind=False)
    assert model.uncertain == ("mu", "F_w_mean") and model.known == {"l_f": 1.55}
    assert model.theta_names == ("mu_mean", "mu_std", "F_w_mean_low", "F_w_mean_high")
    theta = Settings.from_config(c).uncertainty.theta(("mu", "l_f", "F_w_mean"))
    assert theta.tolist() == [1.0, 0.2, -400.0, 400.0]
    a, b = model.moments(theta), ref.moments(theta)
    assert np.array_equal(a.mean, b.mean) and np.array_equal(a.variance, b.variance)
    # a known mean wind (low == high) is a fixed input, not a degenerate interval
    c["uncertainty"]["F_w_mean"] = {"low": 150.0, "high": 150.0}
    assert LSTChaosModel(Settings.from_config(c), uncertain=("mu", "l_f", "F_w_mean"), time_variant_wind=False).theta_names == ("mu_mean", "mu_std")


def test_simulate_gives_a_known_quantity_its_value_in_every_realisation():
    cfg = validate_config(_coarse(l_f_std=0.0, wind={"low": 50.0, "high": 50.0}))
    ds = simulate_ensemble(Settings.from_config(cfg), "lst", samples=20)
    assert np.all(ds["l_f"].values == 1.55) and np.all(ds["F_w_mean"].values == 50.0) and ds["mu"].values.std() > 0.1


@pytest.mark.long(6)
def test_known_l_f_end_to_end(tmp_path):
    """Data of a car whose l_f is fixed (std 0, 400 realisations), identified with l_f declared
    known: accepted, l_f left out of the fit and reported as fixed, mu recovered within 0.03
    (its standard error is 0.2 / sqrt(400) = 0.01: 3 SE), converged without warnings."""
    cfg = _coarse(l_f_std=0.0)
    (tmp_path / "known.yaml").write_text(yaml.safe_dump(cfg))
    data, out = tmp_path / "fixed_lf.nc", tmp_path / "est"
    assert main(["simulate", "--model", "lst", "--samples", "400", "--config", str(tmp_path / "known.yaml"), "--out", str(data)]) == 0
    assert main(["identify", str(data), "--config", str(tmp_path / "known.yaml"), "--out", str(out), "--m-load", "100"]) == 0
    est = json.loads((out / "estimate.json").read_text())
    assert est["fixed"]["l_f"] == 1.55 and est["l_f"] == [1.55, 0.0] and est["standard_errors"]["l_f"] == [0.0, 0.0]
    assert "l_f_mean" not in est["intervals_95"]
    assert est["mu"][0] == pytest.approx(1.0, abs=0.03)
    assert est["converged"] is True and est["warnings"] == [], est["warnings"]


@pytest.mark.long(6)
def test_a_std_at_zero_is_an_answer_not_a_failure(tmp_path, capsys):
    """The same data identified with l_f uncertain: l_f std lands at the lower end of its
    search; that is the answer "no spread" (a note with a one-sided bound that contains 0), not
    the "data lie outside what the model reaches" failure. (The sample's l_f spread is 0, but
    the estimate is not always at the bound: the sampling error of the other parameters' spread
    can ask for a small l_f std, e.g. 0.016 with the wind spread of +-400 N; with a known mean
    wind of 100 N in the data, on the 0.02 s grid and this seed, it is at the bound.)"""
    (tmp_path / "known.yaml").write_text(yaml.safe_dump(_coarse(l_f_std=0.0, wind={"low": 100.0, "high": 100.0}, dt=0.02)))
    (tmp_path / "free.yaml").write_text(yaml.safe_dump(_coarse(l_f_std=0.2, dt=0.02)))
    data, out = tmp_path / "fixed_lf.nc", tmp_path / "est"
    assert main(["simulate", "--model", "lst", "--samples", "400", "--config", str(tmp_path / "known.yaml"), "--out", str(data)]) == 0
    assert main(["identify", str(data), "--config", str(tmp_path / "free.yaml"), "--out", str(out), "--m-load", "100"]) == 0
    est = json.loads((out / "estimate.json").read_text())
    assert est["l_f"][1] < 1e-3 and est["standard_errors"]["l_f"][1] is None
    lo, hi = est["intervals_95"]["l_f_std"]
    assert lo == 0.0 and 0.0 < hi < 0.05
    assert est["converged"] is True and not any("outside what the model reaches" in w for w in est["warnings"])
    assert any("l_f std is estimated at zero" in n for n in est["notes"])
    assert "note: l_f std is estimated at zero" in capsys.readouterr().out


def test_discover_baseline_holds_a_known_quantity(config):
    """StructureFit with l_f known (index 2, 3 fixed): the fit moves mu and the wind only, l_f
    stays at its value with a std of exactly 0, its Jacobian columns are zero, and the free
    parameters reach the truth of exact model data (the model's own statistics at the truth, 24
    realisations on common random numbers: exact to the optimiser's tolerance, 1e-3 relative)
    from 10 % away. Held at a wrong l_f (1.45 m), the fit stays there and the misfit grows."""
    from uqdrive.inference.discrepancy.band import statistic_scale
    from uqdrive.inference.discrepancy.fit import StructureFit
    from uqdrive.vehicle.augmented import AugmentedSimulator
    from uqdrive.vehicle.effects import ModelStructure

    c = copy.deepcopy(config)
    c["uncertainty"]["l_f"]["std"] = 0.0
    assert dict(Settings.from_config(c).layout.known) == {2: 1.55, 3: 0.0}
    t = np.arange(301) * 0.01
    delta = np.deg2rad(5.0) * np.sin(2 * np.pi * t / 2.0)
    sim = AugmentedSimulator.drawn(Settings.from_config(c), t, delta, 25.0, 24, np.random.default_rng(11), stride=4)
    index = np.arange(1, sim.output_time.size)
    truth = np.array([1.0, 0.2, 1.55, 0.0, -400.0, 400.0])
    noise = np.full(4, 1e-8)
    measured = StructureFit(sim, index, noise).statistics(truth, ModelStructure())
    x = sim.simulate(truth, ModelStructure())
    scale = statistic_scale(x, index) + 1e-6
    start = truth * [1.1, 1.1, 1.0, 1.0, 1.1, 0.9]
    fit = StructureFit(sim, index, noise, fixed=dict(Settings.from_config(c).layout.known)).fit(measured, scale, start)
    assert fit.theta_[2] == 1.55 and fit.theta_[3] == 0.0
    assert np.all(fit.jacobian_[:, 2:4] == 0.0) and np.all(np.any(fit.jacobian_[:, [0, 1, 4, 5]] != 0.0, axis=0))
    assert fit.theta_[[0, 1, 4, 5]] == pytest.approx(truth[[0, 1, 4, 5]], rel=1e-3)
    held = StructureFit(sim, index, noise, fixed={2: 1.45, 3: 0.0}).fit(measured, scale, start)
    assert held.theta_[2] == 1.45 and held.chi2_ > 100 * max(fit.chi2_, 1e-6)  # held at a wrong value: not moved to the truth

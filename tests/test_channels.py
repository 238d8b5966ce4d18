"""Measured data as cars record them: any subset of the channels psi, psi_dot, beta, y and the
lateral acceleration a_y; units checked (a_y in g converted); the identifiability of a channel
set; identification from the yaw rate and the lateral acceleration only."""

import copy
import json
import re

import numpy as np
import pytest
import xarray as xr
import yaml

from uqdrive.cli.identify import identify_file
from uqdrive.cli.main import main
from uqdrive.inference.identifiability import channel_observability, observability_analysis, unidentifiable_parameters
from uqdrive.io import MIN_RUNS, STANDARD_GRAVITY, DataError, present_channels, speed_profile, validate_ensemble, write_dataset
from uqdrive.vehicle.channels import CHANNELS, ChannelChaosModel
from uqdrive.vehicle.chaos import LSTChaosModel
from uqdrive.vehicle.montecarlo import simulate_ensemble
from uqdrive.vehicle.noise import add_noise
from uqdrive.vehicle.single_track import VehicleParameters, lateral_acceleration_map, lst_matrices

from conftest import tiny_config
from test_edge_validation import files_under, refused
from uqdrive.settings import Settings

UNCERTAIN = ("mu", "l_f", "F_w_mean")


def coarse(config):
    """The default config on a coarse grid (dt 0.05 s, 4 s) without gusts: a fast reference."""
    cfg = copy.deepcopy(config)
    cfg["time"] = {"t_end": 4.0, "dt": 0.05, "step": 0.05}
    cfg["wind"]["sigma"] = 0.0
    return cfg


@pytest.fixture(scope="module")
def lst_data(config):
    return simulate_ensemble(Settings.from_config(coarse(config)), "lst", samples=300, seed=3)


def test_a_y_is_the_force_sum_and_v_times_beta_dot_plus_yaw_rate():
    """a_y = C x + D u equals v (beta_dot + psi_dot) with beta_dot from row 3 of (5.4) (theory:
    both are the lateral forces over the mass); a sensor-free identity, to rounding."""
    p = VehicleParameters(mu=np.array([0.6, 1.0]), l_f=np.array([1.3, 1.6]), m_load=np.array([50.0, 200.0]))
    A, B, W = lst_matrices(p)
    C, D_delta, D_w = lateral_acceleration_map(p)
    rng = np.random.default_rng(0)
    x, delta, F_w = rng.normal(size=(2, 4)), 0.03, 400.0
    beta_dot = np.einsum("ni,ni->n", A[:, 2], x) + B[:, 2] * delta + W[:, 2] * F_w
    expected = p.v_c * (beta_dot + x[:, 1])
    got = np.einsum("ni,ni->n", C, x) + D_delta * delta + D_w * F_w
    np.testing.assert_allclose(got, expected, rtol=1e-12)


# -- the data schema ----------------------------------------------------------------------------------
def test_any_non_empty_channel_subset_is_accepted(lst_data):
    for keep in (["psi_dot", "a_y"], ["y"], ["beta", "a_y"], list(CHANNELS)):
        ds = lst_data.drop_vars([c for c in CHANNELS if c not in keep])
        assert present_channels(validate_ensemble(ds)) == tuple(c for c in CHANNELS if c in keep)


def test_a_y_in_g_is_converted_and_noted(lst_data):
    ds = lst_data.copy()
    ds["a_y"] = (ds["a_y"] / STANDARD_GRAVITY).assign_attrs(units="g")
    out = validate_ensemble(ds)
    np.testing.assert_allclose(out["a_y"].values, lst_data["a_y"].values, rtol=1e-15)
    assert out["a_y"].attrs["units"] == "m/s^2" and "from g to m/s^2" in out.attrs["conversions"]


@pytest.mark.parametrize("corrupt, needle", [
    (lambda d: d.assign(a_y=d["a_y"].assign_attrs(units="ft/s^2")), "'a_y' has units 'ft/s^2'"),
    (lambda d: d.assign(a_y=d["a_y"] * 100.0), "'a_y' reaches"),  # a file in cm/s^2 labelled m/s^2
    (lambda d: d.drop_vars(list(CHANNELS)), "no usable channel"),
    (lambda d: d.assign(v=("time", np.full(d.sizes["time"], -19.4), {"units": "m/s"})), "variable 'v' reaches -19.4"),
    (lambda d: d.assign(v=("time", np.where(d["time"] > 1, np.nan, 19.4), {"units": "m/s"})), "'v' holds"),
    (lambda d: d.assign(v=("time", np.full(d.sizes["time"], 70.0), {"units": "km/h"})), "'v' has units 'km/h'"),
])
def test_bad_channels_are_refused(lst_data, corrupt, needle):
    with pytest.raises(DataError, match=re.escape(needle)):
        validate_ensemble(corrupt(lst_data.copy()))


def test_a_constant_v_is_the_constant_speed(lst_data):
    ds = lst_data.assign(v=("time", np.full(lst_data.sizes["time"], 19.0), {"units": "m/s"}))
    assert speed_profile(validate_ensemble(ds)) is None
    ramp = np.linspace(19.0, 15.0, lst_data.sizes["time"])
    np.testing.assert_array_equal(speed_profile(validate_ensemble(ds.assign(v=("time", ramp, {"units": "m/s"})))), ramp)


# -- the model's channels -----------------------------------------------------------------------------
def test_states_through_the_channel_model_are_the_chaos_models(config):
    cfg = coarse(config)
    model = LSTChaosModel(Settings.from_config(cfg), uncertain=UNCERTAIN, time_variant_wind=False, order=2, quadrature_points=4, fixed={"m_load": 100.0})
    theta = Settings.from_config(cfg).uncertainty.theta(UNCERTAIN)
    ref = model.moments(theta)
    got = ChannelChaosModel(model, ["y", "psi_dot"]).moments(theta)
    np.testing.assert_array_equal(got.mean, ref.mean[[3, 1]])
    # the variance sums the same squares through a vector, not a matrix, product: same to rounding
    np.testing.assert_allclose(got.variance, ref.variance[[3, 1]], rtol=1e-13, atol=0)


def test_a_y_moments_match_monte_carlo(config):
    """PCE moments of a_y against 2000 LST runs: the mean within 4 standard errors of the Monte
    Carlo mean (std / sqrt(n)) plus 1e-3 of its peak (PCE truncation), the std within 5 %
    (its Monte Carlo error is 1/sqrt(2 n) = 1.6 %)."""
    cfg = coarse(config)
    ds = simulate_ensemble(Settings.from_config(cfg), "lst", samples=2000, seed=11)
    model = LSTChaosModel(Settings.from_config(cfg), uncertain=UNCERTAIN, time_variant_wind=False, order=2, quadrature_points=4, fixed={"m_load": 100.0})
    r = ChannelChaosModel(model, ["a_y"]).moments(Settings.from_config(cfg).uncertainty.theta(UNCERTAIN))
    a = ds["a_y"].values
    se = a.std(0, ddof=1) / np.sqrt(a.shape[0])
    assert np.all(np.abs(r.mean[0] - a.mean(0)) <= 4 * se + 1e-3 * np.abs(a.mean(0)).max())
    assert np.max(np.abs(r.std[0] - a.std(0, ddof=1))) <= 0.05 * a.std(0).max()


def test_a_y_gradient_is_the_derivative(config):
    cfg = coarse(config)
    model = LSTChaosModel(Settings.from_config(cfg), uncertain=UNCERTAIN, time_variant_wind=False, order=2, quadrature_points=4, fixed={"m_load": 100.0})
    cm = ChannelChaosModel(model, ["a_y", "psi_dot"])
    theta = Settings.from_config(cfg).uncertainty.theta(UNCERTAIN)
    assert_moment_gradients(cm, theta, variance=True)


def assert_moment_gradients(cm, theta, variance):
    """The analytic gradients of a channel model's mean (and variance) against central
    differences, step 1e-6 relative: error O(h^2), far below the 1e-6 tolerance."""
    r = cm.moments(theta, gradient=True)
    for k in range(theta.size):
        h = 1e-6 * max(abs(theta[k]), 1.0)
        up, down = (cm.moments(theta + s * h * np.eye(theta.size)[k]) for s in (1, -1))
        np.testing.assert_allclose(r.mean_gradient[k], (up.mean - down.mean) / (2 * h), atol=1e-6 * np.abs(r.mean_gradient[k]).max())
        if variance:
            np.testing.assert_allclose(r.variance_gradient[k], (up.variance - down.variance) / (2 * h),
                                       atol=1e-6 * np.abs(r.variance_gradient[k]).max())


# -- identifiability ----------------------------------------------------------------------------------
def test_all_states_reproduce_the_thesis_rank_test(config):
    full = observability_analysis(Settings.from_config(config))
    mine = channel_observability(Settings.from_config(config), ["psi", "psi_dot", "beta", "y"])
    assert mine.rank == full.rank and mine.removal_rank == full.removal_rank


def test_channel_sets_and_what_they_separate(config):
    # with m_load free, m_load and the mean wind only scale each other (W = 1 / (m v)), any channels
    assert set(unidentifiable_parameters(Settings.from_config(config), ["psi_dot", "a_y"])) == {"m_load", "F_w_mean"}
    # identify's parameters (m_load known): the IMU alone separates them; so does the yaw rate alone
    assert unidentifiable_parameters(Settings.from_config(config), ["psi_dot", "a_y"], UNCERTAIN) == {}
    assert unidentifiable_parameters(Settings.from_config(config), ["psi_dot"], UNCERTAIN) == {}
    # the yaw angle alone leaves the lateral position unobservable (y integrates psi)
    assert channel_observability(Settings.from_config(config), ["psi"], UNCERTAIN).unidentifiable == ["y"]


# -- identification from an IMU -----------------------------------------------------------------------
def _imu_file(ds, path, noise=0.01, seed=5):
    rng = np.random.default_rng(seed)
    out = ds.drop_vars(["psi", "beta", "y", "spun"])
    for c in ("psi_dot", "a_y"):
        out[c] = out[c].copy(data=add_noise(out[c].values, noise, rng))
    write_dataset(out, path)
    return out


def test_identify_on_yaw_rate_and_lateral_acceleration_recovers_mu(config, lst_data, tmp_path):
    """300 LST runs with 1 % noise (5.6), psi_dot and a_y only: mu's mean and std within 0.05 of
    the runs' own (the issue's tolerance; the fit starts at the config's values, 0.05 away from
    none of them by construction, so a fit that ignores the data fails on the std)."""
    cfg = coarse(config)
    ds = _imu_file(lst_data, tmp_path / "imu.nc")
    start = copy.deepcopy(cfg)
    start["uncertainty"]["mu"].update(mean=0.8, std=0.3)  # start away from the truth
    out = identify_file(start, tmp_path / "imu.nc", "std", None, 0, tmp_path / "est")
    mu = ds["mu"].values
    assert out["channels"] == ["psi_dot", "a_y"] and out["converged"], out["warnings"]
    assert abs(out["mu"][0] - mu.mean()) < 0.05 and abs(out["mu"][1] - mu.std(ddof=1)) < 0.05
    assert any("without beta" in w for w in out["warnings"])
    assert (tmp_path / "est" / "fit.png").exists()


def test_fewer_than_ten_runs_is_one_clear_error(tmp_path, capsys):
    folder = tmp_path
    cfg = tiny_config(samples=MIN_RUNS - 1)
    config = folder / "tiny.yaml"
    config.write_text(yaml.safe_dump(cfg))
    data = folder / "tiny.nc"
    assert main(["simulate", "--model", "lst", "--config", str(config), "--out", str(data)]) == 0
    capsys.readouterr()
    before = files_under(folder)
    err = refused(capsys, main(["identify", str(data), "--config", str(config), "--out", str(folder / "out")]), "9 run(s)", "at least 10")
    assert "record more runs" in err
    assert files_under(folder) == before
    assert main(["discover", str(data), "--config", str(config), "--out", str(folder / "d")]) == 2
    assert "at least 10" in capsys.readouterr().err
    assert files_under(folder) == before


@pytest.mark.parametrize("corrupt, needle", [
    (lambda d: d.assign(a_y=d["a_y"].assign_attrs(units="km/h/s")), "'a_y' has units"),
    (lambda d: d.assign(v=("time", np.full(d.sizes["time"], np.nan), {"units": "m/s"})), "'v' holds"),
    (lambda d: d.assign(v=("time", -np.ones(d.sizes["time"]), {"units": "m/s"})), "'v' reaches"),
    (lambda d: d.drop_vars(list(CHANNELS)), "no usable channel"),
])
def test_bad_channels_on_the_command_line(tmp_path, capsys, corrupt, needle):
    config = tmp_path / "tiny.yaml"
    config.write_text(yaml.safe_dump(tiny_config()))
    data = tmp_path / "tiny.nc"
    assert main(["simulate", "--model", "lst", "--config", str(config), "--out", str(data)]) == 0
    capsys.readouterr()
    bad = tmp_path / "bad.nc"
    corrupt(xr.load_dataset(data)).to_netcdf(bad)
    before = files_under(tmp_path)
    refused(capsys, main(["identify", str(bad), "--config", str(config), "--out", str(tmp_path / "out")]), needle)
    assert files_under(tmp_path) == before


def test_identify_warns_when_the_channels_cannot_identify_a_parameter(tmp_path, monkeypatch):
    """The rank test's verdict reaches estimate.json's warnings (no channel subset leaves mu, l_f
    or the mean wind open at the default car, so the test's verdict is stood in for)."""
    import uqdrive.inference.identifiability as ident

    cfg = tiny_config()
    ds = simulate_ensemble(Settings.from_config(cfg), "lst", samples=12, seed=1).drop_vars(["psi", "beta", "y"])
    write_dataset(ds, tmp_path / "imu.nc")
    asked = []
    monkeypatch.setattr(ident, "unidentifiable_parameters", lambda c, ch, p: asked.append(ch) or {"l_f": "beta"})
    out = identify_file(cfg, tmp_path / "imu.nc", "std", None, 0, tmp_path / "est")
    assert asked == [("psi_dot", "a_y")]
    assert any(w.startswith("l_f cannot be identified from the channels psi_dot, a_y") for w in out["warnings"])
    on_disk = json.loads((tmp_path / "est" / "estimate.json").read_text())
    assert on_disk["warnings"] == out["warnings"] and on_disk["channels"] == ["psi_dot", "a_y"]
    # the sampling error of 12 runs: std / sqrt(n) and std / sqrt(2 (n - 1))
    sd = out["mu"][1]
    assert out["sampling_errors"]["mu"] == pytest.approx([sd / np.sqrt(12), sd / np.sqrt(22)], rel=1e-12)

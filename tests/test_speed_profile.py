"""A speed that changes during the run: the speed ramp, the time-varying single-track model in the
Monte Carlo simulator and the chaos model, the constant-speed path unchanged, and identification
from the yaw rate and lateral acceleration along a braking ramp."""

import copy
from dataclasses import replace

import numpy as np
import pytest

from uqdrive.cli.identify import identify_file
from uqdrive.io import validate_ensemble, write_dataset
from uqdrive.studies.manoeuvres import MANOEUVRES, SPEED_PROFILES, braking_in_turn, speed_command
from uqdrive.vehicle.channels import ChannelChaosModel
from uqdrive.vehicle.chaos import LSTChaosModel
from uqdrive.vehicle.montecarlo import simulate_ensemble
from uqdrive.vehicle.noise import add_noise
from uqdrive.vehicle.single_track import VehicleParameters, lst_matrices, lst_matrices_at_speed
from uqdrive.settings import SpeedRamp

from test_channels import assert_moment_gradients
from uqdrive.settings import Settings

UNCERTAIN = ("mu", "l_f", "F_w_mean")
RAMP = {"start_kmh": 70.0, "end_kmh": 50.0, "t_start": 0.5, "duration": 3.0}  # 29 % slower


def coarse(config, dt=0.05, ramp=None):
    cfg = copy.deepcopy(config)
    cfg["time"] = {"t_end": 4.0, "dt": dt, "step": dt}
    cfg["wind"]["sigma"] = 0.0
    if ramp:
        cfg["montecarlo"]["speed_profile"] = dict(ramp)
    return cfg


def test_speed_ramp_golden_values():
    v = SpeedRamp(72.0, 36.0, duration=3.0, t_start=0.5).on([0.0, 0.5, 2.0, 3.5, 9.0])
    np.testing.assert_allclose(v, [20.0, 20.0, 15.0, 10.0, 10.0], rtol=1e-15)


def test_matrices_at_a_speed_are_the_lst_at_that_speed():
    p = VehicleParameters(mu=np.array([0.7, 1.1]))
    A, B, W = lst_matrices_at_speed(p, 15.0)
    for x, y in zip((A, B, W), lst_matrices(replace(p, v_c=15.0))):
        np.testing.assert_array_equal(x, y)
    A2, _, _ = lst_matrices_at_speed(p, 15.0, v_dot=-3.0)
    np.testing.assert_allclose(A2[:, 2, 2] - A[:, 2, 2], 0.2, rtol=1e-12)  # -v_dot / v
    A2[:, 2, 2] = A[:, 2, 2]
    np.testing.assert_array_equal(A2, A)


def test_constant_speed_ensembles_are_unchanged(config):
    """Without montecarlo.speed_profile the states come from the time-invariant path, bit for bit;
    a "profile" that never changes gives the same states through the time-varying path to
    rounding (both are exact discretisations)."""
    cfg = coarse(config)
    ds = simulate_ensemble(Settings.from_config(cfg), "lst", samples=50, seed=2)
    assert "v" not in ds and ds.attrs["v_c"] == pytest.approx(70 / 3.6)
    flat = simulate_ensemble(Settings.from_config(coarse(config, ramp={"start_kmh": 70.0, "end_kmh": 70.0, "duration": 1.0})), "lst", samples=50, seed=2)
    for s in ("psi", "psi_dot", "beta", "y", "a_y"):
        np.testing.assert_allclose(flat[s].values, ds[s].values, rtol=1e-9, atol=1e-12 * np.abs(ds[s].values).max())


def test_ramp_ensemble_carries_v_and_validates(config):
    ds = simulate_ensemble(Settings.from_config(coarse(config, ramp=RAMP)), "nlst", samples=12, seed=2)
    assert "v_c" not in ds.attrs and ds["v"].attrs["units"] == "m/s"
    validate_ensemble(ds)
    np.testing.assert_allclose(ds["v"].values[[0, -1]], [70 / 3.6, 50 / 3.6])


def test_nlst_along_a_ramp_is_the_ltv_lst_for_small_steering(config):
    """At 0.2 deg of steering the tyres stay linear: the NLST with the speed term follows the LTV
    LST to within 1 % of the response (the Magic Formula's curvature is second order). RK4 needs
    its usual 5 ms step: the lower speed makes the dynamics faster."""
    cfg = coarse(config, ramp=RAMP)
    cfg["time"]["step"] = 0.005
    cfg["steering"]["delta_max_deg"] = 0.2
    cfg["uncertainty"]["F_w_mean"].update(low=0.0, high=1e-9)
    cfg["uncertainty"]["mu"]["std"] = 0.05  # no realisation near mu = 0, where the tyres saturate at once
    lst, nlst = (simulate_ensemble(Settings.from_config(cfg), m, samples=20, seed=4) for m in ("lst", "nlst"))
    for s in ("psi_dot", "beta", "a_y"):
        scale = np.abs(lst[s].values).max()
        assert np.max(np.abs(nlst[s].values - lst[s].values)) < 0.01 * scale, s


def test_chaos_model_along_the_ramp_matches_monte_carlo(config):
    """Moments along the ramp against 2000 LTV LST runs: the mean within 4 Monte Carlo standard
    errors plus 1e-3 of the peak (PCE truncation), the std within 5 % (MC error 1.6 %)."""
    cfg = coarse(config, ramp=RAMP)
    ds = simulate_ensemble(Settings.from_config(cfg), "lst", samples=2000, seed=9)
    model = LSTChaosModel(Settings.from_config(cfg), uncertain=UNCERTAIN, time_variant_wind=False, order=2, quadrature_points=4, fixed={"m_load": 100.0})
    r = ChannelChaosModel(model, ["psi_dot", "a_y", "y"], speed=ds["v"].values).moments(Settings.from_config(cfg).uncertainty.theta(UNCERTAIN))
    for i, c in enumerate(r.channels):
        x = ds[c].values
        se = x.std(0, ddof=1) / np.sqrt(x.shape[0])
        assert np.all(np.abs(r.mean[i] - x.mean(0)) <= 4 * se + 1e-3 * np.abs(x.mean(0)).max()), c
        assert np.max(np.abs(r.std[i] - x.std(0, ddof=1))) <= 0.05 * x.std(0).max(), c
    # the ramp matters: at constant speed the yaw rate's mean at the end differs by far more
    const = ChannelChaosModel(model, ["psi_dot"]).moments(Settings.from_config(cfg).uncertainty.theta(UNCERTAIN))
    assert abs(const.mean[0, -1] - r.mean[0, -1]) > 0.05 * np.abs(r.mean[0]).max()


def test_ltv_gradient_is_the_derivative(config):
    cfg = coarse(config, dt=0.1)
    model = LSTChaosModel(Settings.from_config(cfg), uncertain=UNCERTAIN, time_variant_wind=False, order=1, quadrature_points=2, fixed={"m_load": 100.0})
    cm = ChannelChaosModel(model, ["a_y", "beta"], speed=SpeedRamp(**RAMP).on(model.time))
    theta = Settings.from_config(cfg).uncertainty.theta(UNCERTAIN)
    assert_moment_gradients(cm, theta, variance=False)


def test_identify_along_a_braking_ramp_recovers_mu(config, tmp_path):
    """psi_dot and a_y of 250 LST runs braking from 70 to 50 km/h (29 %) with 1 % noise: mu's mean
    and std within 0.05 of the runs' own, from a start 0.2 / 0.1 away."""
    cfg = coarse(config, dt=0.1, ramp=RAMP)
    ds = simulate_ensemble(Settings.from_config(cfg), "lst", samples=250, seed=3)
    rng = np.random.default_rng(5)
    imu = ds.drop_vars(["psi", "beta", "y", "spun"])
    for c in ("psi_dot", "a_y"):
        imu[c] = imu[c].copy(data=add_noise(imu[c].values, 0.01, rng))
    write_dataset(imu, tmp_path / "ramp.nc")
    start = coarse(config, dt=0.1)
    start["uncertainty"]["mu"].update(mean=0.8, std=0.3)
    start["identification"]["optimiser"] = "gauss_newton"
    out = identify_file(start, tmp_path / "ramp.nc", "std", None, 0, tmp_path / "est")
    mu = ds["mu"].values
    assert out["converged"] and out["speed"].startswith("profile"), out
    assert abs(out["mu"][0] - mu.mean()) < 0.05 and abs(out["mu"][1] - mu.std(ddof=1)) < 0.05


def test_braking_in_a_turn_is_a_manoeuvre():
    t = np.linspace(0.0, 8.0, 81)
    delta = braking_in_turn(t, amplitude_deg=2.0, t_start=1.0)
    assert delta[0] == 0.0 and delta[-1] == pytest.approx(np.deg2rad(2.0))
    v = speed_command("braking_in_turn", t)
    assert v[0] > v[-1] and (v[0] - v[-1]) / v[0] >= 0.2
    assert SPEED_PROFILES["braking_in_turn"][0] is braking_in_turn and "braking_in_turn" not in MANOEUVRES

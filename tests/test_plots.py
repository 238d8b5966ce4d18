"""Every figure function draws from small datasets and saves a PNG."""

import numpy as np
import pytest

from uqdrive.plots import data as plots
from uqdrive.plots import pce as pce_plots
from uqdrive.vehicle.montecarlo import kle_from_config, simulate_ensemble
from uqdrive.vehicle.statistics import ensemble_statistics, kl_divergence_series, noise_statistics
from uqdrive.studies.kle import kle_dataset


@pytest.fixture(scope="module")
def stats(config):
    out = {}
    for model in ("lst", "nlst"):
        ds = simulate_ensemble(config, model, samples=6)
        out[model] = ensemble_statistics(ds, "keep")
        out[f"{model}_noise"] = noise_statistics(ds, [0.0, 0.1], [np.random.default_rng(i) for i in range(2)], "keep")
    return out


def _saved(fig, tmp_path, name):
    path = tmp_path / f"{name}.png"
    plots.save_figure(fig, path)
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.long(6)
def test_all_figures(config, stats, tmp_path):
    kle = kle_dataset(config, kle_from_config(config), np.linspace(0, 10, 101), 3, np.random.default_rng(0))
    _saved(plots.tyre_curves(config["figures"]["tyre_surfaces"]), tmp_path, "2_3")
    _saved(plots.kle_realisations(kle), tmp_path, "5_2")
    _saved(plots.kle_eigenfunctions(kle), tmp_path, "7_1")
    _saved(plots.ensemble_band(stats["lst"], 3.0, "LST"), tmp_path, "6_1")
    _saved(plots.ensemble_band(stats["nlst_noise"], 3.0, "A", noise_index=1), tmp_path, "A")
    _saved(plots.noise_levels(stats["lst_noise"]), tmp_path, "6_3")
    _saved(plots.lst_vs_nlst(stats["lst"], stats["nlst"]), tmp_path, "6_5")
    kl = kl_divergence_series(stats["nlst"], stats["lst"]).to_dataset()
    _saved(plots.kl_divergence(kl), tmp_path, "6_6")


def test_pce_figures(config, stats, tmp_path):
    from uqdrive.vehicle.montecarlo import monte_carlo_moments
    from uqdrive.studies.pce import convergence_study, pce_dataset
    from uqdrive.vehicle.chaos import LSTChaosModel

    model = LSTChaosModel(config, order=1, quadrature_points=2)
    pce = pce_dataset(config, model, model.moments(model.theta_from_config(config, model.uncertain)))
    _saved(pce_plots.pce_vs_monte_carlo(pce, stats["lst"]), tmp_path, "5_3")
    _saved(pce_plots.sobol_indices(pce), tmp_path, "5_4")
    mean, std, n = monte_carlo_moments(config, "lst", 20, 10)
    _saved(pce_plots.pce_convergence(convergence_study(config, [1], [2, 3], mean, std, n)), tmp_path, "conv")


def test_wheelslip_figures(tmp_path):
    from uqdrive.plots import wheelslip as pw
    from uqdrive.config import load_config
    from uqdrive.wheelslip.quarter_car import QuarterCar
    from uqdrive.studies.wheelslip import calibration_dataset, closed_loop_dataset, gp_dataset

    from conftest import REPO

    small = load_config(REPO / "config" / "test.yaml")
    car = QuarterCar.from_config(small)
    gp = gp_dataset(small, 10, np.random.default_rng(0))
    hyper = {"v1": gp.attrs["v1"], "g": np.atleast_1d(gp.attrs["g"]), "v0": gp.attrs["v0"]}
    cal = calibration_dataset(small, 10, 1, hyper, np.random.default_rng(1))
    _saved(pw.friction_curves(car, [0.5, 0.9]), tmp_path, "4")
    _saved(pw.gp_function(gp), tmp_path, "5")
    _saved(pw.gp_slope(gp), tmp_path, "6")
    _saved(pw.pole_locations(gp), tmp_path, "7")
    _saved(pw.pid_schedule_figure(car, {"paper": -0.0787}, (5, 40)), tmp_path, "sched")
    _saved(pw.calibration_figure([cal]), tmp_path, "cal")
    _saved(pw.closed_loop_figure(closed_loop_dataset(small, gp, np.random.default_rng(2))), tmp_path, "cl")


def test_identification_figures(config, tmp_path):
    import xarray as xr

    from uqdrive.plots import identification as pi

    rng = np.random.default_rng(0)
    theta = np.array([1.0, 0.2, 1.55, 0.2, -400, 400]) * (1 + 0.05 * rng.normal(size=(2, 2, 6)))
    ds = xr.Dataset(
        {"theta": (("run", "estimate", "parameter"), theta), "w2": (("run", "estimate", "distribution"), rng.random((2, 2, 3))),
         "w2_thesis": (("run", "estimate", "distribution"), rng.random((2, 2, 3))), "truth": ("parameter", [1.0, 0.2, 1.55, 0.2, -400, 400])},
        coords={"run": [1, 2], "estimate": ["LST-STD", "NLST-STD"], "distribution": ["mu", "l_f", "F_w_mean"]},
    )
    _saved(pi.w2_per_run(ds, ["LST-STD", "NLST-STD"], "t"), tmp_path, "67")
    _saved(pi.w2_against(ds, [0.1, 0.2], "x", ["LST-STD"], "t"), tmp_path, "611")
    _saved(pi.distributions(ds, "NLST-STD", "t"), tmp_path, "B")
    _saved(pi.tyre_curves_estimated(config, {"NLST-STD": 0.8}), tmp_path, "610")


def test_control_figures(tmp_path):
    from uqdrive.plots import control as pc
    from uqdrive.config import load_config
    from uqdrive.studies.control import closed_loop_monte_carlo, gains_dataset, gamma_sweep

    from conftest import REPO

    small = load_config(REPO / "config" / "test.yaml")
    g = gains_dataset(small)
    mc = closed_loop_monte_carlo(small, {str(c): g["K"].sel(controller=c).values for c in g["controller"].values}, "lst", 10, 1)
    _saved(pc.closed_loop_bands("t", g, mc, ["LQR", "SLQR"]), tmp_path, "617")
    _saved(pc.gamma_sweep_figure(gamma_sweep(small)), tmp_path, "sweep")


def test_bayes_figures(tmp_path):
    from uqdrive.plots import bayes as pbay
    from uqdrive.studies.bayes import posterior_case, prepare_data
    from uqdrive.config import load_config
    from uqdrive.vehicle.montecarlo import simulate_ensemble

    from conftest import REPO

    small = load_config(REPO / "config" / "test.yaml")
    x, nv = prepare_data(small, simulate_ensemble(small, "lst"))
    ds = posterior_case(small, x, nv, np.random.default_rng(0), ensembles=2, max_steps=60)
    _saved(pbay.corner_plot(ds, "t"), tmp_path, "corner")
    _saved(pbay.trace_plot(ds, "t"), tmp_path, "trace")

"""Every figure function draws what its dataset holds: the lines and bands drawn, axis labels
with units, data equal to the dataset's, read from the figure's artists. Saving (PNG, atomic, the
crop rule) is checked on a few; the DAG run saves every figure of the workflow twice."""

import re

import matplotlib.pyplot as plt
import numpy as np
import pytest

from uqdrive.plots import data as plots
from uqdrive.plots import pce as pce_plots
from uqdrive.vehicle.montecarlo import simulate_ensemble, wind_kle
from uqdrive.vehicle.single_track import STATES, STATE_UNITS
from uqdrive.vehicle.statistics import ensemble_statistics, kl_divergence_series, noise_statistics
from uqdrive.studies.kle import kle_dataset
from uqdrive.settings import Settings

UNIT = re.compile(r"\[[^\]]+\]")


@pytest.fixture(scope="module")
def stats(config):
    out = {}
    for model in ("lst", "nlst"):
        ds = simulate_ensemble(Settings.from_config(config), model, samples=6)
        out[model] = ensemble_statistics(ds, "keep")
        out[f"{model}_noise"] = noise_statistics(ds, [0.0, 0.1], [np.random.default_rng(i) for i in range(2)], "keep")
    return out


def _drawn(fig, min_axes=1, units=True):
    """The axes of ``fig`` that hold data; each holds a line, band, image or patch and, with
    ``units``, the figure labels some axis with a unit in brackets. The figure is closed."""
    axes = [ax for ax in fig.axes if ax.lines or ax.collections or ax.images or ax.patches]
    labels = [label for ax in fig.axes for label in (ax.get_xlabel(), ax.get_ylabel())]
    plt.close(fig)
    assert len(axes) >= min_axes, f"{len(axes)} axes hold data, {min_axes} expected"
    if units:
        assert any(UNIT.search(label) for label in labels), labels
    return axes


def _ydata(ax):
    return [np.asarray(line.get_ydata(), float) for line in ax.lines]


def _band_extent(ax):
    """y range of the filled bands (fill_between's PolyCollections) of ``ax``."""
    ys = np.concatenate([path.vertices[:, 1] for c in ax.collections for path in c.get_paths()])
    return ys.min(), ys.max()


def _saved(fig, tmp_path, name):
    path = tmp_path / f"{name}.png"
    plots.save_figure(fig, path)
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    return path


def test_save_figure_writes_the_canvas_of_a_laid_out_figure_and_crops_one_without_layout(tmp_path):
    """A constrained-layout figure keeps its canvas (figsize x dpi pixels); a figure without a
    layout engine (corner's) is cropped to what it draws; no temporary is left."""
    from PIL import Image

    fig, ax = plt.subplots(figsize=(4, 3), constrained_layout=True)
    ax.plot([0, 1], [0, 1])
    assert Image.open(_saved(fig, tmp_path, "laid_out")).size == (440, 330)
    fig = plt.figure(figsize=(4, 3))
    fig.add_axes((0.4, 0.4, 0.2, 0.2)).plot([0, 1], [0, 1])
    width, height = Image.open(_saved(fig, tmp_path, "cropped")).size
    assert width < 300 and height < 250
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cropped.png", "laid_out.png"]


@pytest.mark.long(4)
def test_data_figures_draw_the_datasets(config, stats, tmp_path):
    kle = kle_dataset(config, wind_kle(Settings.from_config(config)), np.linspace(0, 10, 101), 3, np.random.default_rng(0))
    surfaces = config["figures"]["tyre_surfaces"]
    ax_x, ax_y = _drawn(plots.tyre_curves(surfaces), 2)
    assert len(ax_x.lines) == len(ax_y.lines) == len(surfaces)
    assert all(abs(np.max(np.abs(y)) - c["D"]) < 1e-3 for y, c in zip(_ydata(ax_x), surfaces.values()))  # peak = D
    direct, expanded = _drawn(plots.kle_realisations(kle), 2)
    assert len(direct.lines) == len(expanded.lines) == kle.sizes["path"] and np.array_equal(_ydata(expanded)[0], kle["kle_sample"].values[0])
    (ax,) = _drawn(plots.kle_eigenfunctions(kle))
    assert [list(y) for y in _ydata(ax)] == [list(f) for f in kle["eigenfunction"].values]

    lst, nlst = stats["lst"], stats["nlst"]
    axes = _drawn(plots.ensemble_band(lst, 3.0, "LST"), 4)
    for ax, state in zip(axes, STATES):
        m, s = lst["mean"].sel(state=state).values, lst["std"].sel(state=state).values
        assert np.array_equal(_ydata(ax)[0], m) and ax.get_ylabel() == f"{state} [{STATE_UNITS[state]}]"
        assert np.allclose(_band_extent(ax), ((m - 3 * s).min(), (m + 3 * s).max()), rtol=1e-12, atol=1e-15)
    assert axes[-1].get_xlabel() == "time [s]"
    noisy = stats["nlst_noise"].isel(noise=1)
    for ax, state in zip(_drawn(plots.ensemble_band(stats["nlst_noise"], 2.0, "A", noise_index=1), 4), STATES):
        assert np.array_equal(_ydata(ax)[0], noisy["mean"].sel(state=state).values)
    grid = np.array(_drawn(plots.noise_levels(stats["lst_noise"]), 8)).reshape(4, 2)
    for (mean_ax, var_ax), state in zip(grid, STATES):
        sel = stats["lst_noise"].sel(state=state)
        assert len(mean_ax.lines) == stats["lst_noise"].sizes["noise"]
        assert np.array_equal(_ydata(mean_ax)[1], sel["mean"].isel(noise=1).values)
        assert np.array_equal(_ydata(var_ax)[1], sel["std"].isel(noise=1).values ** 2)
    for ax, state in zip(_drawn(plots.lst_vs_nlst(lst, nlst), 4), STATES):
        assert [list(y) for y in _ydata(ax)] == [list(lst["mean"].sel(state=state).values), list(nlst["mean"].sel(state=state).values)]
    kl = kl_divergence_series(nlst, lst).to_dataset()
    for ax, state in zip(_drawn(plots.kl_divergence(kl), 4), STATES):
        assert ax.get_yscale() == "log" and np.array_equal(_ydata(ax)[0], kl["kl_divergence"].sel(state=state).values, equal_nan=True)


def test_pce_figures(config, stats, tmp_path):
    from uqdrive.vehicle.montecarlo import monte_carlo_moments
    from uqdrive.studies.pce import convergence_study, pce_dataset
    from uqdrive.vehicle.chaos import LSTChaosModel

    model = LSTChaosModel(Settings.from_config(config), order=1, quadrature_points=2)
    pce = pce_dataset(config, model, model.moments(Settings.from_config(config).uncertainty.theta(model.uncertain)))
    axes = _drawn(pce_plots.pce_vs_monte_carlo(pce, stats["lst"]), 4)
    assert [ax.get_ylabel() for ax in axes] == [f"{s} [{STATE_UNITS[s]}]" for s in STATES]
    assert all(ax.get_ylabel() == "S_1 [-]" for ax in _drawn(pce_plots.sobol_indices(pce), 4))
    mean, std, n = monte_carlo_moments(Settings.from_config(config), "lst", 20, 10)
    _drawn(pce_plots.pce_convergence(convergence_study(config, [1], [2, 3], mean, std, n)), 2, units=False)  # N_PCE, relative errors


def test_wheelslip_figures(tmp_path):
    from uqdrive.plots import wheelslip as pw
    from uqdrive.wheelslip.quarter_car import closed_loop_poles
    from uqdrive.config import load_config
    from uqdrive.wheelslip.quarter_car import QuarterCar
    from uqdrive.studies.wheelslip import calibration_dataset, closed_loop_dataset, gp_dataset

    from conftest import REPO

    small = load_config(REPO / "config" / "test.yaml")
    car = QuarterCar.from_settings(Settings.from_config(small).wheelslip)
    gp = gp_dataset(small, 10, np.random.default_rng(0))
    hyper = {"v1": gp.attrs["v1"], "g": np.atleast_1d(gp.attrs["g"]), "v0": gp.attrs["v0"]}
    cal = calibration_dataset(small, 10, 1, hyper, np.random.default_rng(1))
    assert len(_drawn(pw.friction_curves(car, [0.5, 0.9]))[0].lines) >= 2
    _drawn(pw.gp_function(gp))
    _drawn(pw.gp_slope(gp))
    (ax,) = _drawn(pw.pole_locations(gp))
    true = next(line for line in ax.lines if line.get_label() == "true slope")
    assert np.allclose(np.sort(true.get_ydata()), np.sort(closed_loop_poles(gp.attrs["zeta_true"], gp.attrs["omega_0"]).imag))
    _drawn(pw.pid_schedule_figure(car, {"paper": -0.0787}, (5, 40)), 2)
    _drawn(pw.calibration_figure([cal]), units=False)  # a coverage share
    _drawn(pw.closed_loop_figure(closed_loop_dataset(small, gp, np.random.default_rng(2))))


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
    assert all(len(ax.lines) + len(ax.collections) + len(ax.patches) >= 2 for ax in _drawn(pi.w2_per_run(ds, ["LST-STD", "NLST-STD"], "t"), 3, units=False))  # normalised W2 per run
    _drawn(pi.w2_against(ds, [0.1, 0.2], "x", ["LST-STD"], "t"), units=False)
    axes = _drawn(pi.distributions(ds, "NLST-STD", "t"), 3)
    assert [ax.get_ylabel() for ax in axes] == ["density [-]", "density [1/m]", "density [1/N]"]
    truth = next(line for line in axes[0].lines if line.get_label() == "true")
    assert np.max(truth.get_ydata()) == pytest.approx(1 / (np.sqrt(2 * np.pi) * 0.2), rel=1e-4)  # N(1, 0.2) at its mode (grid 2/599)
    assert len(axes[0].lines) == 1 + ds.sizes["run"]  # one estimate per run and the truth
    _drawn(pi.tyre_curves_estimated(config, {"NLST-STD": 0.8}))


def test_control_figures(tmp_path):
    from uqdrive.plots import control as pc
    from uqdrive.config import load_config
    from uqdrive.studies.control import closed_loop_monte_carlo, gains_dataset, gamma_sweep

    from conftest import REPO

    small = load_config(REPO / "config" / "test.yaml")
    g = gains_dataset(small)
    mc = closed_loop_monte_carlo(small, {str(c): g["K"].sel(controller=c).values for c in g["controller"].values}, "lst", 10, 1)
    _drawn(pc.closed_loop_bands("t", g, mc, ["LQR", "SLQR"]), 5)
    _drawn(pc.gamma_sweep_figure(gamma_sweep(small)), 2, units=False)  # gamma against dimensionless costs


def test_bayes_figures(tmp_path):
    from uqdrive.plots import bayes as pbay
    from uqdrive.studies.bayes import posterior_case, prepare_data
    from uqdrive.config import load_config
    from uqdrive.vehicle.montecarlo import simulate_ensemble

    from conftest import REPO

    small = load_config(REPO / "config" / "test.yaml")
    x, nv = prepare_data(small, simulate_ensemble(Settings.from_config(small), "lst"))
    ds = posterior_case(small, x, nv, np.random.default_rng(0), ensembles=2, max_steps=60)
    p = ds.sizes["parameter"]
    assert len(_drawn(pbay.corner_plot(ds, "t"), p * (p + 1) // 2, units=False)) == p * (p + 1) // 2  # parameter names, no units
    assert len(_drawn(pbay.trace_plot(ds, "t"), p, units=False)) == p

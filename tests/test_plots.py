"""Every figure function draws from small datasets and saves a PNG."""

import numpy as np
import pytest

from uqdrive import plots
from uqdrive.montecarlo import kle_from_config, simulate_ensemble
from uqdrive.statistics import ensemble_statistics, kl_divergence_series, noise_statistics
from uqdrive.wind import kle_dataset


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
    from uqdrive.montecarlo import monte_carlo_moments
    from uqdrive.pce_study import convergence_study, pce_dataset
    from uqdrive.pce_vehicle import LSTChaosModel

    model = LSTChaosModel(config, order=1, quadrature_points=2)
    pce = pce_dataset(config, model, model.moments(model.theta_from_config(config, model.uncertain)))
    _saved(plots.pce_vs_monte_carlo(pce, stats["lst"]), tmp_path, "5_3")
    _saved(plots.sobol_indices(pce), tmp_path, "5_4")
    mean, std, n = monte_carlo_moments(config, "lst", 20, 10)
    _saved(plots.pce_convergence(convergence_study(config, [1], [2, 3], mean, std, n)), tmp_path, "conv")

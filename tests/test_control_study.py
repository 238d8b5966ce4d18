import numpy as np
import pytest

from uqdrive.config import load_config
from uqdrive.studies.control import closed_loop_monte_carlo, distribution_from_theta, gains_dataset, gamma_sweep, lqr_mean_gain
from uqdrive.studies.scorecard import control_rows

from conftest import REPO


@pytest.fixture(scope="module")
def small():
    return load_config(REPO / "config" / "test.yaml")


def test_lqr_mean_gain_is_6_1(config):
    assert lqr_mean_gain(config) == pytest.approx([-1.854, -0.052, -0.487, -0.316], abs=5e-4)


def test_gains_monte_carlo_and_scorecard(small):
    g = gains_dataset(small, np.array([0.75, 0.16, 1.7, 0.05, -360.0, 570.0]))
    assert list(g["controller"].values) == ["LQR", "SLQR", "SLQR identified"]
    rows = control_rows(g)
    assert len(rows) == 4 and all(r.source == "thesis eq. (6.2)" for r in rows)
    K = {str(c): g["K"].sel(controller=c).values for c in g["controller"].values}
    for model in ("lst", "nlst"):
        mc = closed_loop_monte_carlo(small, K, model, 30, 2)
        assert mc["stable"].values.all()  # every realisation settles in the lane
        assert np.abs(mc["y"].values[:, :, -1]).max() < 0.05


def test_distribution_from_theta_reports_abs_std(config):
    d = distribution_from_theta(config, [0.8, -0.2, 1.5, 0.2, -300, 500])
    assert d.mu == (0.8, 0.2) and d.F_w_mean == (-300, 500)


def test_gamma_sweep_shapes(small):
    sw = gamma_sweep(small)
    assert sw["K"].shape == (len(small["control"]["gamma_sweep"]), 4)
    assert np.all(sw["variance_cost"] <= sw.attrs["lqr_variance_cost"] * 1.001)

import numpy as np
import pytest

from uqdrive.config import load_config
from uqdrive.studies.scorecard import wheelslip_rows
from uqdrive.studies.wheelslip import calibration_dataset, closed_loop_dataset, gp_dataset, gp_from_dataset

from conftest import REPO


@pytest.fixture(scope="module")
def small():
    return load_config(REPO / "config" / "test.yaml")


def test_gp_dataset_and_refit(small):
    ds = gp_dataset(small, 10, np.random.default_rng(0))
    assert ds.attrs["true_Gamma"] == pytest.approx(0.3882, abs=5e-5)
    assert ds.attrs["zeta_minus"] < 0.5 < ds.attrs["zeta_plus"]
    gp = gp_from_dataset(ds)
    m, v = gp.predict_slope(np.array([0.15]))
    assert m[0] == pytest.approx(ds.attrs["E_Gamma"], rel=1e-8)


def test_calibration_and_closed_loop_and_scorecard(small):
    gp = gp_dataset(small, 10, np.random.default_rng(1))
    hyper = {"v1": gp.attrs["v1"], "g": np.atleast_1d(gp.attrs["g"]), "v0": gp.attrs["v0"]}
    cal = calibration_dataset(small, 10, 1, hyper, np.random.default_rng(2))
    assert cal.attrs["ml_sets"] == small["wheelslip"]["calibration"]["sets"] and cal.attrs["mcmc_sets"] == 1
    cl = closed_loop_dataset(small, gp, np.random.default_rng(3))
    assert cl.sizes["curve"] == small["wheelslip"]["closed_loop"]["draws"] + 1
    assert cl.attrs["true_stable"] == 1
    rows = wheelslip_rows(small, [cal])
    names = " ".join(r.quantity for r in rows)
    for key in ("K_p", "T_i", "zeta", "coverage"):
        assert key in names
    assert all(r.status == "pass" for r in rows if "coverage" not in r.quantity)

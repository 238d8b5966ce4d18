import numpy as np
import pytest

from uqdrive.wheelslip.quarter_car import QuarterCar
from uqdrive.wheelslip.calibration import binomial_interval, calibration, fit_friction_gp, posterior_curves, prior_calibration, slope_interval_mcmc, training_data

CAR = QuarterCar()


def test_training_data_has_the_noise_free_origin():
    slip, mu, exact = training_data(CAR, 10, (0.0, 0.1), 0.05, np.random.default_rng(0))
    assert slip.shape == (11,) and slip[0] == 0.0 and mu[0] == 0.0 and exact.tolist() == [True] + [False] * 10
    assert np.all((slip[1:] >= 0) & (slip[1:] <= 0.1))


def test_exact_calibration_with_known_hyperparameters():
    """Truths drawn from the GP prior, predicted with the same hyperparameters: the 95 % slope
    interval covers 95 % of them. 1000 draws: the Clopper-Pearson interval must contain 0.95."""
    hyper = {"v1": 0.3, "g": [1e-3, 400.0], "v0": 0.0025}
    x = np.concatenate([[0.0], np.linspace(0.0, 0.1, 10)])
    hits, n = prior_calibration(hyper, x, 0.15, 1000, np.random.default_rng(11))
    lo, hi = binomial_interval(hits, n)
    assert lo <= 0.95 <= hi, (hits, n)


def test_binomial_interval():
    lo, hi = binomial_interval(95, 100)
    assert lo == pytest.approx(0.887, abs=0.002) and hi == pytest.approx(0.984, abs=0.002)
    assert binomial_interval(0, 10)[0] == 0.0 and binomial_interval(10, 10)[1] == 1.0


def test_calibration_and_mcmc_remedy_run():
    rng = np.random.default_rng(3)
    lines = []
    res = calibration(CAR, 10, 4, (0.0, 0.1), 0.05, 2, rng, {"sets": 1, "walkers": 10, "steps": 40, "burn": 10}, log=lines.append, log_every=3)
    assert res["ml_bounds"].shape == (4, 2) and res["mcmc_bounds"].shape == (1, 2)
    assert np.all(res["ml_bounds"][:, 0] < res["ml_bounds"][:, 1])
    # progress every 3 sets and at the end, for the workflow's log
    assert [line.split(",")[0] for line in lines] == ["calibration (10 points): 3/4 training sets", "calibration (10 points): 4/4 training sets"]
    assert " 1 with emcee" in lines[-1]


def test_mcmc_interval_is_reproducible():
    gp, _, _ = fit_friction_gp(CAR, 10, (0.0, 0.1), 0.05, 2, np.random.default_rng(4))
    a = slope_interval_mcmc(gp, 0.15, np.random.default_rng(9), walkers=10, steps=40, burn=10, draws=30)
    b = slope_interval_mcmc(gp, 0.15, np.random.default_rng(9), walkers=10, steps=40, burn=10, draws=30)
    assert a == b and a[2][0] < a[0] < a[2][1]


def test_posterior_curves_match_the_posterior():
    gp, _, _ = fit_friction_gp(CAR, 10, (0.0, 0.1), 0.05, 2, np.random.default_rng(5))
    grid = np.linspace(0, 0.3, 31)
    draws = posterior_curves(gp, grid, 4000, np.random.default_rng(6))
    m, v = gp.predict(grid)
    assert np.abs(draws.mean(axis=0) - m).max() < 5 * np.sqrt(v.max() / 4000) + 1e-9

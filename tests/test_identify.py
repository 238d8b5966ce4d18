"""The estimator on exact model data: it must find the truth, guard physics, report failures."""

import copy

import numpy as np
import pytest

from uqdrive.identify import COSTS, DistributionEstimator, WeightContext, cost_weights, default_bounds, initial_guess
from uqdrive.pce_vehicle import LSTChaosModel

TRUTH = np.array([1.0, 0.2, 1.55, 0.2, -400.0, 400.0])


@pytest.fixture(scope="module")
def model(config):
    return LSTChaosModel(config, uncertain=("mu", "l_f", "F_w_mean"), time_variant_wind=False)


@pytest.fixture(scope="module")
def data(model):
    r = model.moments(TRUTH)
    return r.mean, r.std


def test_recovers_the_truth_from_model_data(model, data):
    """Data made by the model itself: the optimum is the truth (to 1e-4 relative), from 25 %."""
    th0 = initial_guess(TRUTH, 0.2, 0.25, np.random.default_rng(1))
    est = DistributionEstimator(model, "std").fit(*data, th0)
    assert est.converged_
    assert est.theta_ == pytest.approx(TRUTH, rel=1e-3, abs=0.5)
    assert np.all(np.isfinite(est.theta_std_))


def test_initial_guess_bounds_5_34():
    g = initial_guess(TRUTH, 0.1, 0.1, np.random.default_rng(0))
    assert np.abs(np.abs(g / TRUTH - 1) - 0.1) == pytest.approx(np.zeros(6), abs=1e-12)
    g = initial_guess(TRUTH, 0.0, 0.25, np.random.default_rng(0))
    assert np.all(np.abs(g / TRUTH - 1) <= 0.25)


def test_weights():
    ctx = WeightContext(delta=np.array([0.0, 0.5]), kl_divergence=np.array([[np.nan, 1.0]] * 4))
    assert cost_weights("std", ctx, (4, 2)) == pytest.approx(np.ones((4, 2)))
    assert cost_weights("inp", ctx, (4, 2))[0] == pytest.approx([1.0, np.exp(-0.5)])
    assert cost_weights("dst", ctx, (4, 2))[0] == pytest.approx([1.0, np.exp(-1.0)])
    with pytest.raises(ValueError, match="KL divergence"):
        cost_weights("dst", WeightContext(np.zeros(2)), (4, 2))
    with pytest.raises(ValueError, match="unknown cost 'l1'"):
        cost_weights("l1", ctx, (4, 2))
    assert set(COSTS) == {"std", "inp", "dst"}


def test_non_physical_start_is_a_clear_error(model, data):
    bad = TRUTH.copy()
    bad[0] = 0.2  # mu mean 0.2 with std 0.2: negative friction at the outer quadrature nodes
    with pytest.raises(ValueError, match="not physical"):
        DistributionEstimator(model, "std").fit(*data, bad)


def test_guarded_search_stays_physical(model, data):
    """Scaled data pulls the fit towards negative friction: the guard keeps it physical."""
    est = DistributionEstimator(model, "std", max_iter=60).fit(data[0] * 3.0, data[1] * 0.1, TRUTH)
    lo, hi = np.array(default_bounds(model.theta_names, 2.85)).T
    assert np.all(est.theta_ >= lo - 1e-9) and np.all(est.theta_ <= hi + 1e-9)
    assert est.theta_[0] - 2.4 * est.theta_[1] > 0  # mu > 0 at the outer Gauss-Hermite node


def test_multistart_reaches_the_optimum_from_far(model, data):
    th0 = initial_guess(TRUTH, 0.9, 0.9, np.random.default_rng(5))
    th0[0] = max(th0[0], 0.6)  # keep the start physical; the global stage does the rest
    th0[1] = min(th0[1], 0.2)
    lo, hi = sorted(th0[4:])
    th0[4], th0[5] = lo, hi
    est = DistributionEstimator(model, "std", starts=3, rng=np.random.default_rng(0)).fit(*data, th0)
    assert est.theta_[0] == pytest.approx(1.0, abs=0.01) and est.theta_[2] == pytest.approx(1.55, abs=0.02)

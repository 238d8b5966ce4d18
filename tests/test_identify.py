"""The estimator on exact model data: it must find the truth, guard physics, report failures."""

import numpy as np
import pytest

from hypothesis import given, settings
from hypothesis import strategies as st

from uqdrive.inference.identify import COSTS, OPTIMISERS, STATE_SCALES, DistributionEstimator, WeightContext, cost_weights, default_bounds, initial_guess, state_weights
from uqdrive.vehicle.chaos import LSTChaosModel

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


@pytest.mark.parametrize("scale", sorted(STATE_SCALES))
def test_recovers_the_truth_with_every_state_scale(model, data, scale):
    """Exact model data: rescaling the residuals per state must not move the optimum (1e-3 rel)."""
    th0 = initial_guess(TRUTH, 0.1, 0.1, np.random.default_rng(2))
    est = DistributionEstimator(model, "std", state_scale=scale).fit(*data, th0)
    assert est.theta_ == pytest.approx(TRUTH, rel=1e-3, abs=0.5)


def test_gauss_newton_reaches_the_quasi_newton_optimum(model, data):
    """Perturbed data (a non-zero residual at the optimum, as with measured data): trust-region
    Gauss-Newton and L-BFGS-B stop at the same optimum (parameters 1e-4 relative, cost 1e-8),
    Gauss-Newton in fewer iterations (J'J is the Hessian model a sum of squares offers)."""
    mean, std = data
    rng = np.random.default_rng(7)
    noisy = (mean * (1 + 0.02 * rng.normal(size=mean.shape)), std * (1 + 0.02 * rng.normal(size=std.shape)))
    th0 = initial_guess(TRUTH, 0.1, 0.2, np.random.default_rng(3))
    fits = {name: DistributionEstimator(model, "std", state_scale="rms_mean", optimiser=name).fit(*noisy, th0) for name in OPTIMISERS}
    qn, gn = fits["lbfgsb"], fits["gauss_newton"]
    assert qn.converged_ and gn.converged_
    assert gn.theta_ == pytest.approx(qn.theta_, rel=1e-4)
    assert gn.cost_ == pytest.approx(qn.cost_, rel=1e-8)
    assert gn.n_iter_ < qn.n_iter_


def test_gauss_newton_rejects_non_physical_steps(model, data):
    """Trial points where the model cannot be evaluated (here: the 2nd and 5th, as a model
    raises outside its physical region) cost the penalty and are rejected; the fit still
    reaches the truth (exact data, 1e-3)."""

    class Refusing:
        theta_names = model.theta_names

        def __init__(self):
            self.calls, self.refused = 0, 0

        def moments(self, theta, gradient=False):
            self.calls += 1
            if gradient and self.calls in (2, 5):
                self.refused += 1
                raise ValueError("outside the physical region")
            return model.moments(theta, gradient=gradient)

    refusing = Refusing()
    th0 = initial_guess(TRUTH, 0.1, 0.2, np.random.default_rng(4))
    est = DistributionEstimator(refusing, "std", optimiser="gauss_newton").fit(*data, th0)
    assert refusing.refused == 2
    assert est.converged_
    assert est.theta_ == pytest.approx(TRUTH, rel=1e-3, abs=0.5)


def test_unknown_optimiser_is_named():
    with pytest.raises(ValueError, match="unknown optimiser 'newton'; choose one of lbfgsb, gauss_newton"):
        DistributionEstimator(object(), optimiser="newton", wheelbase=2.85)


@settings(max_examples=30, deadline=None)
@given(st.lists(st.floats(1e-3, 1e3), min_size=4, max_size=4), st.sampled_from(["rms_mean", "rms_std"]))
def test_unit_free_scales_make_the_cost_independent_of_units(units, scale):
    """Expressing state i in other units (factor c_i) scales its residuals by c_i and its weight
    by 1/c_i^2, so every weighted squared residual is unchanged (relative 1e-12)."""
    rng = np.random.default_rng(0)
    mean, std, resid = rng.normal(size=(4, 50)), rng.uniform(0.1, 1, (4, 50)), rng.normal(size=(4, 50))
    c = np.array(units)[:, None]
    before = state_weights(scale, mean, std)[:, None] * resid**2
    after = state_weights(scale, c * mean, c * std)[:, None] * (c * resid) ** 2
    assert after == pytest.approx(before, rel=1e-12)


def test_state_scale_errors_name_the_problem():
    with pytest.raises(ValueError, match="unknown state scale 'max'"):
        state_weights("max", np.ones((4, 3)), np.ones((4, 3)))
    with pytest.raises(ValueError, match="unknown state scale 'max'"):
        DistributionEstimator(object(), state_scale="max", wheelbase=2.85)
    zero = np.ones((4, 3))
    zero[2] = 0.0
    with pytest.raises(ValueError, match="state scale 'rms_mean' is zero"):
        state_weights("rms_mean", zero, np.ones((4, 3)))
    assert state_weights("none", zero, zero) == pytest.approx(np.ones(4))


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

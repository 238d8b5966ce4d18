import copy

import numpy as np
import pytest

from uqdrive.control.lqr import lqr_gain
from uqdrive.control.slqr import ClosedLoopChaos, LaneKeepingCase, mean_variance_weights
from uqdrive.vehicle.uncertainty import ParameterDistribution
from uqdrive.vehicle.single_track import VehicleParameters, lst_matrices

Q, R = np.diag([1.0, 1.0, 1.0, 10.0]), 100.0


@pytest.fixture(scope="module")
def k_lqr(config):
    A, B, _ = lst_matrices(VehicleParameters.from_config(config))
    return lqr_gain(A, B, Q, R)[0]


def test_weights_5_35():
    assert mean_variance_weights(4, 0.001).tolist() == [0.001, 0.999, 0.999, 0.999]


def test_cost_gradient_matches_finite_differences(config, k_lqr):
    model = ClosedLoopChaos(config, LaneKeepingCase(horizon=1.0), order=1)
    J, g = model.cost(k_lqr, Q, R, 0.3, gradient=True)
    for j in range(4):
        e = np.zeros(4)
        e[j] = 1e-6
        fd = (model.cost(k_lqr + e, Q, R, 0.3) - model.cost(k_lqr - e, Q, R, 0.3)) / 2e-6
        # Central differences carry J's rounding (|J| ~ 137, ~1e-14 relative after 100 steps)
        # divided by h = 1e-6: ~1.4e-6 absolute, whatever the size of the component.
        assert g[j] == pytest.approx(fd, rel=1e-6, abs=2e-6)


def test_pce_closed_loop_matches_monte_carlo(config, k_lqr):
    """Closed-loop PCE moments (N_PCE = 2) against 2000 Monte Carlo runs of the LST: mean within
    4 standard errors and std within 5 % of its maximum, at every time (initial conditions
    uniform: the PCE is exact in them; the parameters enter through order-2 truncation)."""
    from uqdrive.studies.control import closed_loop_monte_carlo

    cfg = copy.deepcopy(config)
    cfg["control"]["simulation_time"] = 3.0
    model = ClosedLoopChaos(cfg, LaneKeepingCase(horizon=3.0, dt=cfg["time"]["dt"]), order=2)
    mean, var, _, _ = model.moments(k_lqr)
    mc = closed_loop_monte_carlo(cfg, {"LQR": k_lqr}, "lst", 2000, 3)
    for i, s in enumerate(("psi", "psi_dot", "beta", "y")):
        x = mc[s].sel(controller="LQR").values
        se = x.std(axis=0, ddof=1) / np.sqrt(x.shape[0]) + 1e-12
        assert np.max(np.abs(mean[i] - x.mean(axis=0)) / se) < 4.5
        assert np.max(np.abs(np.sqrt(var[i]) - x.std(axis=0, ddof=1))) < 0.05 * x.std(axis=0).max()


def test_slqr_without_uncertainty_tends_to_the_lqr(config, k_lqr):
    """With no parameter or wind uncertainty, only the initial state is random; E[integral of
    x'(Q + K'RK)x] is minimised by the LQR gain for every initial state. The discrete sum (5.38)
    is a rectangle rule of that integral, so the SLQR optimum approaches the LQR at O(dt):
    halving dt must roughly halve the distance (measured 0.005 -> 0.002 -> 0.001 s: the beta
    gain goes -9.7 -> -5.5 -> -3.4 towards -0.49; the cost is very flat in it)."""
    cfg = copy.deepcopy(config)
    cfg["wind"]["sigma"] = 0.0
    dist = ParameterDistribution(mu=(1.0, 0.0), m_load=(100.0, 0.0), l_f=(1.55, 0.0), F_w_mean=(0.0, 0.0))
    errors = []
    for dt in (0.004, 0.002):
        model = ClosedLoopChaos(cfg, LaneKeepingCase(horizon=6.0, dt=dt), dist, order=1, quadrature_points=1, time_variant_wind=False)
        K, _ = model.synthesise(k_lqr * 1.05, Q, R, 0.5)
        errors.append(np.linalg.norm(K - k_lqr))
    assert errors[1] < 0.7 * errors[0]

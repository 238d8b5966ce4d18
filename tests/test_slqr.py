import copy
import dataclasses

import numpy as np
import pytest

from uqdrive.control.lqr import lqr_gain
from uqdrive.control.slqr import ClosedLoopChaos, LaneKeepingCase, mean_variance_weights
from uqdrive.numerics.threads import single_blas_thread
from uqdrive.vehicle.montecarlo import wind_kle
from uqdrive.vehicle.uncertainty import ParameterDistribution
from uqdrive.vehicle.single_track import VehicleParameters, lst_matrices
from uqdrive.settings import Settings

Q, R = np.diag([1.0, 1.0, 1.0, 10.0]), 100.0


@pytest.fixture(scope="module")
def k_lqr(config):
    A, B, _ = lst_matrices(VehicleParameters.from_settings(Settings.from_config(config)))
    return lqr_gain(A, B, Q, R)[0]


# -- exact checks on a deterministic plant (only the initial state random): fast and tight --------
@pytest.fixture(scope="module")
def deterministic(config):
    """No parameter uncertainty, gusts switched off by time_variant_wind=False alone (the config's
    sigma = 100 N stays), a constant mean wind of 150 N, initial state uniform in y0 in
    [0.25, 1.75] m and psi0 in [-4, 4] deg: the chaos (order 1) is exact in those germs."""
    cfg = copy.deepcopy(config)
    cfg["wind"]["kle_quadrature"] = 80  # the KLE is built even with gusts off: keep it small
    assert cfg["wind"]["sigma"] > 0
    dist = ParameterDistribution(mu=(1.0, 0.0), m_load=(100.0, 0.0), l_f=(1.55, 0.0), F_w_mean=(150.0, 150.0))
    lane = LaneKeepingCase(y_low=0.25, y_high=1.75, psi_deg=4.0, horizon=2.0, dt=0.01)
    model = ClosedLoopChaos(Settings.from_config(cfg), lane, dist, order=1, quadrature_points=1, time_variant_wind=False)
    assert model.projector.n_linear == 2  # the two initial-condition germs only
    A, B, W = lst_matrices(VehicleParameters.from_settings(Settings.from_config(cfg), mu=1.0, m_load=100.0, l_f=1.55))
    return model, A, B, W


def _exact_moments(A, B, W, K, times):
    """x(t) = e^{(A+BK)t} x0 + int_0^t e^{(A+BK)s} ds W 150 (one augmented matrix exponential):
    mean from x0 = (0, 0, 0, 1); covariance from the two uniform germs (variance 1/3 each)
    scaled by the half-ranges 0.75 m (y) and 4 deg (psi)."""
    from scipy.linalg import expm

    M = np.zeros((5, 5))
    M[:4, :4] = A + np.outer(B, K)
    M[:4, 4] = 150.0 * W
    mean, cov = [], []
    for t in times:
        E = expm(M * t)
        a, b = E[:4, 3] * 0.75, E[:4, 0] * np.deg2rad(4.0)
        mean.append(E[:4, 3] + E[:4, 4])
        cov.append((np.outer(a, a) + np.outer(b, b)) / 3.0)
    return np.array(mean).T, np.array(cov)


def test_lane_keeping_case_defaults_and_config(config):
    """Defaults are the thesis' Fig 5.8 case (y0 ~ U(0, 1.75) m, psi0 ~ U(-5, 5) deg, T = 2 s on
    the 0.01 s grid), the same as config/config.yaml; from_config reads every field and a
    horizon given explicitly wins."""
    case = LaneKeepingCase()
    assert (case.y_low, case.y_high, case.psi_deg, case.horizon, case.dt) == (0.0, 1.75, 5.0, 2.0, 0.01)
    c = dict(config, control=dict(config["control"], y0=[0.1, 1.5], psi0_deg=3.0, horizon=4.0), time=dict(config["time"], dt=0.02))
    assert LaneKeepingCase.from_settings(Settings.from_config(c)) == LaneKeepingCase(0.1, 1.5, 3.0, 4.0, 0.02)
    assert LaneKeepingCase.from_settings(Settings.from_config(c), horizon=1.0).horizon == 1.0
    assert LaneKeepingCase.from_settings(Settings.from_config(config)) == case
    with pytest.raises(dataclasses.FrozenInstanceError):
        case.dt = 0.02  # a case is a value: hashable, shared safely between models


def test_state_and_steering_moments_and_cost_equal_the_exact_solution(deterministic, k_lqr):
    """Deterministic plant, random initial state: the PCE is exact, and the first-order hold is
    exact for the constant wind, so the state and steering moments equal the matrix-exponential
    solution to rounding (rel 1e-9 of each series' maximum), and the cost (5.38) equals
    sum_t [gamma m'Sm + (1 - gamma) tr(S Cov)], S = Q + K'RK, with a non-diagonal Q (rel 1e-10)."""
    model, A, B, W = deterministic
    K = 1.1 * k_lqr
    mean, var, u_mean, u_var = model.moments(K)
    ref_mean, ref_cov = _exact_moments(A, B, W, K, model.time)
    assert model.time == pytest.approx(np.arange(201) * 0.01, abs=1e-12)
    assert mean == pytest.approx(ref_mean, abs=1e-9 * np.abs(ref_mean).max())
    assert var == pytest.approx(np.einsum("tii->it", ref_cov), abs=1e-9 * var.max())
    assert u_mean == pytest.approx(K @ ref_mean, abs=1e-9 * np.abs(u_mean).max())
    assert u_var == pytest.approx(np.einsum("i,tij,j->t", K, ref_cov, K), abs=1e-9 * u_var.max())
    Qx = Q + 0.2 * (np.eye(4, k=1) + np.eye(4, k=-1))
    S = Qx + R * np.outer(K, K)
    for gamma in (0.3, 1.0):
        exact = gamma * np.einsum("it,ij,jt->", ref_mean, S, ref_mean) + (1 - gamma) * np.einsum("ij,tji->", S, ref_cov)
        assert model.cost(K, Qx, R, gamma) == pytest.approx(exact, rel=1e-10)
        assert model.cost(K, Qx, R, gamma, gradient=True)[0] == pytest.approx(exact, rel=1e-10)


def test_synthesis_stops_at_a_stationary_point_of_the_cost(deterministic, k_lqr, monkeypatch):
    """BFGS on (5.38) from 25 % away from the LQR gain: the result must be a stationary point of
    the cost itself, checked by central differences of cost() (not by the analytic gradient the
    optimiser used): |dJ/dK| there below 1e-4 of its value at the start (measured 3e-7; BFGS stops
    at gtol 1e-9 of the normalised cost, or on precision loss, as here, where the cost is flat),
    and a lower cost. A cost mis-scaled against its gradient still reaches the optimum (a constant
    factor), so the objective handed to BFGS is checked directly as well."""
    model = deterministic[0]
    K0 = 1.25 * k_lqr

    def fd(K):
        h = 1e-6 * np.maximum(np.abs(K), 1e-3)
        return np.array([(model.cost(K + e, Q, R, 0.3) - model.cost(K - e, Q, R, 0.3)) / (2 * e.max()) for e in np.diag(h)])

    import uqdrive.control.slqr as slqr_module

    handed, real = [], slqr_module.minimize

    def recording(fun, x0, **kwargs):
        handed.append(fun)
        return real(fun, x0, **kwargs)

    monkeypatch.setattr(slqr_module, "minimize", recording)
    with single_blas_thread():  # 28-state matrices: BLAS threads only add overhead (docs/maintainer.md)
        K, res = model.synthesise(K0, Q, R, 0.3)
        # The pair handed to BFGS: the cost normalised to 1 at K0, and its own gradient (central
        # differences with h = 1e-5 |K|: truncation ~h^2, measured 2e-7 relative at 1e-4 |K|, so
        # ~2e-9 here; rounding ~1e-14 |J| / h, measured 1e-7 relative at this step (1e-6 at
        # 1e-6 |K|, where the Taylor-and-doubling exponential's noise reaches the tolerance); rel 1e-6).
        f = handed[0]
        J0, g0 = f(K0)
        h = 1e-5 * np.abs(K0)
        fd0 = np.array([(f(K0 + e)[0] - f(K0 - e)[0]) / (2 * e.max()) for e in np.diag(h)])
    assert J0 == pytest.approx(1.0, rel=1e-14) and g0 == pytest.approx(fd0, rel=1e-6)
    assert np.array_equal(K, res.x)
    assert np.linalg.norm(fd(K)) < 1e-4 * np.linalg.norm(fd(K0))
    assert model.cost(K, Q, R, 0.3) < 0.99 * model.cost(K0, Q, R, 0.3)


def test_gust_variance_equals_the_sum_of_the_kle_modes_responses(config, k_lqr):
    """Deterministic plant and initial state (y0 = 1 m, psi0 = 0), zero mean wind, gusts on: the
    PCE (order 1) is exact in the Gaussian KLE germs, so the state variance is the sum over modes j
    of x_j(t)^2, x_j the closed-loop response to the gust input column times sigma sqrt(lambda_j)
    phi_j(t), and the mean is the unforced response. Reference: scipy.signal.lsim (linear
    interpolation of the input, as the first-order hold); both are exact for the same
    piecewise-linear input, so rel 1e-10 of each series' maximum (measured 3e-15)."""
    from scipy.signal import lsim

    from uqdrive.vehicle.montecarlo import gust_input_column

    cfg = copy.deepcopy(config)
    cfg["wind"]["kle_quadrature"] = 80  # any KLE will do (model and reference share it); 80 points keep it cheap
    dist = ParameterDistribution(mu=(1.0, 0.0), m_load=(100.0, 0.0), l_f=(1.55, 0.0), F_w_mean=(0.0, 0.0))
    model = ClosedLoopChaos(Settings.from_config(cfg), LaneKeepingCase(1.0, 1.0, 0.0, 2.0, 0.01), dist, order=1, quadrature_points=1)
    A, B, W = lst_matrices(VehicleParameters.from_settings(Settings.from_config(cfg), mu=1.0, m_load=100.0, l_f=1.55))
    kle = wind_kle(Settings.from_config(cfg))
    assert model.projector.n_linear == kle.n_modes + 2  # gusts on by default
    Acl, t = A + np.outer(B, k_lqr), model.time
    column = gust_input_column(W, cfg["wind"]["gust_yaw_moment"])
    scale = cfg["wind"]["sigma"] * np.sqrt(kle.eigenvalues)
    var = np.zeros((4, t.size))
    for j in range(kle.n_modes):
        _, _, x = lsim((Acl, column[:, None], np.eye(4), np.zeros((4, 1))), scale[j] * kle.eigenfunctions(t)[j], t)
        var += x.T**2
    _, _, x_free = lsim((Acl, np.zeros((4, 1)), np.eye(4), np.zeros((4, 1))), np.zeros(t.size), t, X0=[0, 0, 0, 1.0])
    mean, pce_var, _, _ = model.moments(k_lqr)
    assert mean == pytest.approx(x_free.T, abs=1e-10 * np.abs(x_free).max())
    for i in range(4):
        assert pce_var[i] == pytest.approx(var[i], abs=1e-10 * var[i].max())


def test_weights_5_35():
    assert mean_variance_weights(4, 0.001).tolist() == [0.001, 0.999, 0.999, 0.999]


@pytest.fixture(scope="module")
def uncertain_order1(config):
    """Every parameter uncertain, gusts on, order 1, 1 s."""
    return ClosedLoopChaos(Settings.from_config(config), LaneKeepingCase(horizon=1.0), order=1)


def test_moments_are_the_chaos_moments_of_the_response(uncertain_order1, k_lqr):
    """Orthonormal chaos: mean = coefficient 0, variance = sum of the squared others, for the
    states and for u = K x (coefficients K c_k), from response() (rel 1e-12). The first term
    (mu) carries 5 % of the steering's standard deviation: no coefficient may be skipped."""
    model = uncertain_order1
    c = model.projector.coefficients(model.response(k_lqr))  # (T, 4, P)
    u = np.einsum("i,tip->tp", k_lqr, c)
    mean, var, u_mean, u_var = model.moments(k_lqr)
    assert mean == pytest.approx(c[:, :, 0].T, rel=1e-12, abs=1e-15)
    assert var == pytest.approx(np.sum(c[:, :, 1:] ** 2, axis=2).T, rel=1e-12, abs=1e-15)
    assert u_mean == pytest.approx(u[:, 0], rel=1e-12, abs=1e-15) and u_var == pytest.approx(np.sum(u[:, 1:] ** 2, axis=1), rel=1e-12, abs=1e-15)
    assert np.abs(u[:, 1]).max() > 0.01 * np.sqrt(u_var.max())  # the first term (mu) matters


def test_cost_gradient_matches_finite_differences(uncertain_order1, k_lqr):
    model = uncertain_order1
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
    model = ClosedLoopChaos(Settings.from_config(cfg), LaneKeepingCase(horizon=3.0, dt=cfg["time"]["dt"]))  # defaults: order 2, 4 points, gusts
    mean, var, u_mean, u_var = model.moments(k_lqr)
    mc = closed_loop_monte_carlo(cfg, {"LQR": k_lqr}, "lst", 2000, 3)
    assert model.projector.chaos.order == 2 and model.projector.nodes.shape == (4**4, 4)
    assert model.projector.n_linear == wind_kle(Settings.from_config(cfg)).n_modes + 2
    for i, s in enumerate(("psi", "psi_dot", "beta", "y")):
        x = mc[s].sel(controller="LQR").values
        se = x.std(axis=0, ddof=1) / np.sqrt(x.shape[0]) + 1e-12
        assert np.max(np.abs(mean[i] - x.mean(axis=0)) / se) < 4.5
        assert np.max(np.abs(np.sqrt(var[i]) - x.std(axis=0, ddof=1))) < 0.05 * x.std(axis=0).max()
    # The steering u = K x: the same bounds (mean within 4.5 standard errors at every one of the
    # 301 times: a family-wise 5 % level needs ~3.9; std within 5 % of its maximum).
    u = mc["delta"].sel(controller="LQR").values
    se = u.std(axis=0, ddof=1) / np.sqrt(u.shape[0]) + 1e-12
    assert np.max(np.abs(u_mean - u.mean(axis=0)) / se) < 4.5
    assert np.max(np.abs(np.sqrt(u_var) - u.std(axis=0, ddof=1))) < 0.05 * u.std(axis=0).max()


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
        model = ClosedLoopChaos(Settings.from_config(cfg), LaneKeepingCase(horizon=6.0, dt=dt), dist, order=1, quadrature_points=1, time_variant_wind=False)
        K, _ = model.synthesise(k_lqr * 1.05, Q, R, 0.5)
        errors.append(np.linalg.norm(K - k_lqr))
    assert errors[1] < 0.7 * errors[0]

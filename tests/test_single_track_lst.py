"""The linear single-track model (5.4) is written once (uqdrive.vehicle.single_track): the RK4 right-hand
side along a speed profile and the lateral acceleration of the simulators take its forces and
coefficients from there, to the last bit (the data sets and fits made with the package are
reproduced exactly, so those comparisons use ``np.array_equal``), and the speed-factored
coefficients are the matrices of (5.4) at every speed."""

import numpy as np
import pytest

from uqdrive.settings import Settings
from uqdrive.vehicle.effects import ModelStructure
from uqdrive.vehicle.single_track import (VehicleParameters, lateral_acceleration_map, linear_axle_forces, lst_lateral_acceleration,
                                          lst_matrices, lst_matrices_at_speed, lst_speed_coefficients, with_compliance_steer)
from uqdrive.vehicle.track_rk4 import LinearTrackRHS, linear_lateral_acceleration, speed_on_half_steps

N = 9


@pytest.fixture(scope="module")
def car(config):
    rng = np.random.default_rng(11)
    return VehicleParameters.from_settings(Settings.from_config(config), mu=rng.uniform(0.5, 1.1, N), m_load=rng.uniform(0.0, 400.0, N),
                                           l_f=rng.uniform(1.1, 1.8, N))


def _states(rng, *shape):
    """psi, psi_dot, beta, y of the size a slalom reaches (rad, rad/s, rad, m)."""
    return rng.normal(size=(4, *shape)) * np.array([0.3, 0.4, 0.05, 2.0]).reshape((4,) + (1,) * len(shape))


def _profile_rhs(p, structure, yaw_gust, rng):
    """A :class:`LinearTrackRHS` braking from 25 to 15 m/s over 2 s, steered and gusted at random."""
    t = np.arange(201) * 0.01
    t_half = np.arange(401) * 0.005
    v, v_dot = speed_on_half_steps(t, 25.0 - 5.0 * np.clip(t, 0.0, 2.0), t_half)
    delta_half = 0.05 * np.sin(3.0 * t_half)
    F_w_half = rng.normal(size=(t_half.size, N)) * 400.0
    return LinearTrackRHS(p, structure, delta_half, F_w_half, yaw_gust, rng.normal(size=N) * 300.0, v, v_dot)


@pytest.mark.parametrize("compliance", [0.0, 0.7])
def test_the_profile_rhs_takes_its_forces_and_acceleration_from_the_shared_functions(car, compliance):
    """LinearTrackRHS.forces and .lateral_acceleration are linear_axle_forces and
    lst_lateral_acceleration of the (compliance-softened) car at the half step's speed and inputs,
    bit for bit, on random states; with compliance the front force differs (the branch is taken)."""
    rng = np.random.default_rng(1)
    rhs = _profile_rhs(car, ModelStructure(compliance_steer=compliance), True, rng)
    p = with_compliance_steer(car, compliance)
    for j in (0, 117, 400):
        x = _states(rng, N)
        F_f, F_r = rhs.forces(x, j)
        want_f, want_r = linear_axle_forces(p, rhs.delta_half[j], x[2], x[1], rhs.v_half[j])
        assert np.array_equal(F_f, want_f) and np.array_equal(F_r, want_r)
        a_y = lst_lateral_acceleration(p, rhs.delta_half[j], x[2], x[1], rhs.F_w_half[j], rhs.v_half[j])
        assert np.array_equal(rhs.lateral_acceleration(x, j), a_y)
        stiff = linear_axle_forces(car, rhs.delta_half[j], x[2], x[1], rhs.v_half[j])[0]
        assert np.array_equal(stiff, want_f) == (compliance == 0.0)


@pytest.mark.parametrize("yaw_gust", [True, False])
def test_the_profile_rhs_is_the_lst_matrices_at_the_local_speed(car, yaw_gust):
    """dx/dt of LinearTrackRHS (its coefficients: lst_speed_coefficients's, bit for bit) equals
    A x + B delta + W F_w of lst_matrices_at_speed at the half step's speed and rate (the gusts'
    yaw moment M_c F_w, or M_c times the mean wind), plus a_lat / v on beta_dot. The two group
    the same products differently (P / v against -(...) / (I_z v)): a few ulps of the largest
    term, so 1e-12 of the terms' magnitude."""
    rng = np.random.default_rng(2)
    a_lat = 0.3
    rhs = _profile_rhs(car, ModelStructure(lateral_acceleration=a_lat), yaw_gust, rng)
    c = lst_speed_coefficients(car)
    for name, field in [("P", "yaw_damping"), ("a12", "yaw_slip"), ("a13", "yaw_steer"), ("W1", "yaw_wind"), ("Q", "slip_yaw"),
                        ("R", "slip_damping"), ("S", "slip_steer"), ("inv_m", "slip_wind")]:
        assert np.array_equal(getattr(rhs, name), np.broadcast_to(getattr(c, field), (N,))), name
    for j in (3, 250):
        x = _states(rng, N)
        out = np.empty_like(x)
        rhs(x, j, out)
        A, B, W = lst_matrices_at_speed(car, rhs.v_half[j], rhs.v_dot_half[j])
        F_w = rhs.F_w_half[j]
        wind_term = W * F_w[:, None]
        if not yaw_gust:  # M_c times the mean wind, over I_z
            wind_term[:, 1] = rhs.M_term
        terms = [np.einsum("nij,jn->in", A, x), B.T * rhs.delta_half[j], wind_term.T]
        want = sum(terms)
        want[2] += a_lat / rhs.v_half[j]
        scale = sum(np.abs(t) for t in terms) + a_lat / rhs.v_half[j]
        assert np.all(np.abs(out - want) <= 1e-12 * scale)


def test_the_ensembles_acceleration_is_the_shared_function_on_realisations_by_time(car):
    """linear_lateral_acceleration of states (4, n, K) is lst_lateral_acceleration with the
    per-realisation parameters broadcast along time, bit for bit, at a constant speed and along a
    profile; and it is the output map C x + D delta + D_w F_w to 1e-12 of its terms."""
    rng = np.random.default_rng(3)
    K = 14
    x, delta, F_w = _states(rng, N, K), 0.04 * rng.normal(size=K), 300.0 * rng.normal(size=(N, K))
    for v in (float(car.v_c), np.linspace(12.0, 30.0, K)):
        for compliance in (0.0, 0.4):
            p = with_compliance_steer(car, compliance)
            a_y = linear_lateral_acceleration(car, x, delta, F_w, v, compliance)
            assert np.array_equal(a_y, lst_lateral_acceleration(p, delta, x[2], x[1], F_w, v))
            # each realisation's own car on its own row: the parameters broadcast along time, not across realisations
            own = np.stack([lst_lateral_acceleration(_one(p, i), delta, x[2, i], x[1, i], F_w[i], v) for i in range(N)])
            assert np.array_equal(a_y, own)
    C, D_delta, D_w = lateral_acceleration_map(car)
    terms = [np.einsum("ni,ink->nk", C, x), D_delta[:, None] * delta, D_w[:, None] * F_w]
    a_y = linear_lateral_acceleration(car, x, delta, F_w, car.v_c)
    assert np.all(np.abs(a_y - sum(terms)) <= 1e-12 * sum(np.abs(t) for t in terms))


def _one(p, i):
    """Realisation ``i`` of per-realisation parameters, its own car with scalar mu, m_load, l_f (and a compliance-softened c_Sf)."""
    pick = lambda a: float(np.asarray(a)[i]) if np.ndim(a) else a  # noqa: E731
    return VehicleParameters(**{f: pick(getattr(p, f)) for f in p.__dataclass_fields__})


def test_the_matrices_are_built_from_the_speed_factored_coefficients(car):
    """The speed-free entries of lst_matrices and lateral_acceleration_map are the coefficients
    themselves (bit for bit); the speed-scaled ones are them over v or v^2 (to rounding, 1e-14),
    scalar and per realisation, and the complex step through them still differentiates (5.4)."""
    for p in (car, VehicleParameters()):
        c = lst_speed_coefficients(p)
        A, B, W = lst_matrices(p)
        C, D_delta, D_w = lateral_acceleration_map(p)
        v = p.v_c
        assert np.array_equal(A[..., 1, 2], c.yaw_slip) and np.array_equal(B[..., 1], c.yaw_steer) and np.array_equal(W[..., 1], c.yaw_wind)
        assert np.array_equal(C[..., 2], c.slip_damping) and np.array_equal(D_delta, c.slip_steer) and np.array_equal(D_w, c.slip_wind)
        np.testing.assert_allclose(A[..., 1, 1], c.yaw_damping / v, rtol=1e-14)
        np.testing.assert_allclose(A[..., 2, 1], c.slip_yaw / v**2 - 1.0, rtol=1e-14)
        np.testing.assert_allclose(A[..., 2, 2], c.slip_damping / v, rtol=1e-14)
        np.testing.assert_allclose(B[..., 2], c.slip_steer / v, rtol=1e-14)
        np.testing.assert_allclose(C[..., 1], c.slip_yaw / v, rtol=1e-14)
    h = 1e-20
    A_c = lst_matrices(VehicleParameters(mu=1.0 + 1j * h))[0]
    A_1, A_2 = lst_matrices(VehicleParameters(mu=1.0 + 1e-6))[0], lst_matrices(VehicleParameters(mu=1.0 - 1e-6))[0]
    # (5.4)'s entries are linear in mu: the central difference is exact but for rounding, ~1e-10 relative
    np.testing.assert_allclose(A_c.imag / h, (A_1 - A_2) / 2e-6, rtol=1e-8, atol=1e-12)


def test_the_steering_column_keeps_its_order_under_a_complex_step(car):
    # A complex product's imaginary part rounds by the order of its factors (l_f c_f against
    # c_f l_f), and the identifications' complex-step gradients, and the fits that follow them, keep
    # the last bits of this order: the column is l_f c_f / I_z as (5.4) writes B.
    rng = np.random.default_rng(5)
    p = VehicleParameters(**{**car.__dict__, "l_f": car.l_f + 1e-20j * rng.normal(size=N), "mu": car.mu + 1e-20j * rng.normal(size=N)})
    _, B, _ = lst_matrices(p)
    assert np.array_equal(B[..., 1], p.l_f * p.c_f / p.I_z)

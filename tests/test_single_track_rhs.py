"""The one right-hand side of the non-linear single-track model (uqdrive.vehicle.dynamics) gives the
Monte Carlo ensembles the numbers of (5.3) written out one expression per state, to the last bit:
the data sets made with the package are reproduced exactly, so the tests compare with
``np.array_equal``, not a tolerance. Sines and cosines come from the half-angle tangent (within
2 ulp of NumPy's, a third of their cost), the course's sine from NumPy (the heading is not bounded)."""

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from uqdrive.settings import Settings, TimeGrid
from uqdrive.numerics.integrate import rk4_fixed_step
from uqdrive.vehicle.dynamics.ensemble import lateral_acceleration
from uqdrive.vehicle.dynamics.engine import EnsembleSimulator
from uqdrive.vehicle.montecarlo import NLST
from uqdrive.vehicle.dynamics import SingleTrackRHS, nlst_rhs
from uqdrive.vehicle.axle_loads import half_angle_sin_cos, half_angle_sin_cos_into
from uqdrive.vehicle.single_track import VehicleParameters

N = 6


def _half_angle(a):
    """sin and cos of ``a`` from t = tan(a / 2): 2 t / (1 + t^2), (1 - t^2) / (1 + t^2)."""
    t = np.tan(0.5 * a)
    inv = 1.0 / (1.0 + t * t)
    return 2.0 * t * inv, (1.0 - t * t) * inv


def _written_out(p, quotient, tyre_sine=lambda a: _half_angle(a)[0]):
    """(5.3) one expression per state, allocating: the balances divided by I_z and m v
    (``quotient``) or multiplied by their inverses, beta_dot with -(v_dot / v) sin beta; the sine
    and cosine of beta by the half-angle tangent, the tyre's sine by ``tyre_sine``."""
    l_f, l_r = np.asarray(p.l_f, float), p.l_r

    def rhs(x, delta, F_w, M_w, v, v_dot=None):
        psi, psi_dot, beta, _ = x
        sin_b, cos_b = _half_angle(beta)
        a_f = -np.arctan((v * sin_b + l_f * psi_dot) / (v * cos_b)) + delta
        a_r = -np.arctan((v * sin_b - l_r * psi_dot) / (v * cos_b))
        F_f = p.F_fz * p.mu * tyre_sine(p.C * np.arctan(p.c_Sf * a_f - p.E * (p.c_Sf * a_f - np.arctan(p.c_Sf * a_f))))
        F_r = p.F_rz * p.mu * tyre_sine(p.C * np.arctan(p.c_Sr * a_r - p.E * (p.c_Sr * a_r - np.arctan(p.c_Sr * a_r))))
        front = F_f * np.cos(delta)
        if quotient:
            psi_ddot = (l_f * front - l_r * F_r + M_w) / p.I_z
            beta_dot = (front + F_r + F_w) * cos_b / (p.m * v) - psi_dot
        else:
            psi_ddot = (l_f * front - l_r * F_r + M_w) * (1.0 / p.I_z)
            beta_dot = (front + F_r + F_w) * cos_b * (1.0 / (p.m * v)) - psi_dot
        if v_dot is not None:
            beta_dot = beta_dot - v_dot / v * sin_b
        return np.stack([psi_dot, psi_ddot, beta_dot, v * np.sin(psi)])

    return rhs


@pytest.fixture(scope="module")
def case(config):
    settings = Settings.from_config(config)
    grid = TimeGrid(3.0, 0.01, 0.005)
    rng = np.random.default_rng(11)
    p = VehicleParameters.from_settings(settings, mu=rng.uniform(0.4, 1.2, N), m_load=rng.uniform(0, 200, N), l_f=rng.uniform(1.4, 1.7, N))
    t_half = grid.fine(2)
    delta = np.deg2rad(5.0) * np.cos(np.pi * t_half / 2.0)
    wind, coeffs = rng.uniform(-400, 400, N), rng.normal(0, 200, (N, 3))
    f_half = np.stack([np.sin((k + 1) * np.pi * t_half / 3.0) for k in range(3)])
    return p, delta, wind, coeffs, f_half, grid


def _ensemble(config, p, delta, wind, coeffs, f_half, grid, gust_yaw=True, v_half=None):
    """States (4, n, K + 1) of the Monte Carlo data sets' simulator on these half-step inputs."""
    settings = Settings.from_config(config)
    settings = replace(settings, wind=replace(settings.wind, gust_yaw_moment=gust_yaw))
    return EnsembleSimulator.driven(settings, grid, delta, f_half, p.v_c, v_half).realise(p, wind, coeffs, NLST)


def _gusts(f_half):
    """The eigenfunctions per half step as contiguous rows, as the ensembles take them (a
    product with a strided column may round differently)."""
    return np.ascontiguousarray(f_half.T)


@pytest.mark.parametrize("gust_yaw", [True, False])
def test_the_ensemble_at_constant_speed_is_5_3_written_out_bit_for_bit(config, case, gust_yaw):
    p, delta, wind, coeffs, f_half, grid = case
    rhs, rows = _written_out(p, quotient=False), _gusts(f_half)

    def f(x, j):
        F_w = wind + coeffs @ rows[j]
        return rhs(x, delta[j], F_w, p.M_c * (F_w if gust_yaw else wind), float(p.v_c))

    want = rk4_fixed_step(f, np.zeros((4, N)), grid.step, grid.n_out * grid.substeps, grid.substeps).transpose(1, 2, 0)
    assert np.array_equal(_ensemble(config, *case, gust_yaw), want)


def test_the_tyre_sine_leaves_the_half_angle_where_the_angle_can_reach_pi(config, case):
    """The Magic Formula's angle C atan(u) stays below C pi / 2; with C = 2 it reaches pi, where
    tan(angle / 2) is infinite: the tyre's sine is then NumPy's (the written-out RHS with the
    half-angle sine differs), at C = 1.9 the half angle's (NumPy's sine differs)."""
    p, delta, wind, coeffs, f_half, grid = case
    rows = _gusts(f_half)

    def run(rhs, q):
        f = lambda x, j: rhs(x, delta[j], wind + coeffs @ rows[j], q.M_c * (wind + coeffs @ rows[j]), float(q.v_c))
        return rk4_fixed_step(f, np.zeros((4, N)), grid.step, grid.n_out * grid.substeps, grid.substeps).transpose(1, 2, 0)

    for C, right, wrong in [(2.0, np.sin, lambda a: _half_angle(a)[0]), (1.9, lambda a: _half_angle(a)[0], np.sin)]:
        q = replace(p, C=C)
        x = _ensemble(config, q, delta, wind, coeffs, f_half, grid)
        assert np.array_equal(x, run(_written_out(q, False, right), q)), C
        assert not np.array_equal(x, run(_written_out(q, False, wrong), q)), C


def test_the_ensemble_along_a_speed_profile_divides_bit_for_bit(config, case):
    """Along a speed profile the balances divide by I_z and m v (the rounding of the ensembles
    along a profile); multiplying by the inverses would differ in the last bits, so this fails."""
    p, delta, wind, coeffs, f_half, grid = case
    v_half = np.linspace(25.0, 15.0, delta.size)
    v_dot = np.gradient(v_half, grid.step / 2.0)
    rhs, rows = _written_out(p, quotient=True), _gusts(f_half)

    def f(x, j):
        F_w = wind + coeffs @ rows[j]
        return rhs(x, delta[j], F_w, p.M_c * F_w, v_half[j], v_dot[j])

    want = rk4_fixed_step(f, np.zeros((4, N)), grid.step, grid.n_out * grid.substeps, grid.substeps).transpose(1, 2, 0)
    x = _ensemble(config, *case, v_half=v_half)
    assert np.array_equal(x, want)
    inverse = _written_out(p, quotient=False)
    other = rk4_fixed_step(lambda x, j: inverse(x, delta[j], wind + coeffs @ rows[j], p.M_c * (wind + coeffs @ rows[j]), v_half[j], v_dot[j]),
                           np.zeros((4, N)), grid.step, grid.n_out * grid.substeps, grid.substeps).transpose(1, 2, 0)
    assert not np.array_equal(x, other)


def test_the_ensembles_lateral_acceleration_is_the_forces_over_the_mass(case):
    """a_y = v (beta_dot + psi_dot) / cos beta with beta_dot of the divided balances, bit for bit;
    with the multiplied ones to rounding (1e-12 of its range: the two differ in the last bits)."""
    p = case[0]
    rng = np.random.default_rng(3)
    x = rng.normal(0, 0.1, (4, N, 5))
    delta, F_w, speed = rng.normal(0, 0.05, 5), rng.normal(0, 300, (N, 5)), np.linspace(20.0, 24.0, 5)
    a_y = lateral_acceleration("nlst", x, p, delta, F_w, speed)
    rhs = _written_out(p, quotient=True)
    for k in range(5):
        dx = rhs(x[:, :, k], delta[k], F_w[:, k], p.M_c * F_w[:, k], float(speed[k]))
        assert np.array_equal(a_y[:, k], speed[k] * (dx[2] + x[1, :, k]) / np.cos(x[2, :, k]))
        assert np.array_equal(nlst_rhs(x[:, :, k], delta[k], F_w[:, k], replace(p, v_c=float(speed[k]))), dx)
        dx = SingleTrackRHS(replace(p, v_c=float(speed[k])), n=N).rates(x[:, :, k], delta[k], F_w[:, k])
        assert np.allclose(a_y[:, k], speed[k] * (dx[2] + x[1, :, k]) / np.cos(x[2, :, k]), rtol=0, atol=1e-12 * np.abs(a_y).max())


@settings(max_examples=50, deadline=None)
@given(arrays(np.float64, st.integers(1, 64), elements=st.floats(-3.1, 3.1)))
def test_half_angle_in_place_is_the_allocating_one_and_numpys_to_rounding(angle):
    """In place, the allocating half-angle sine and cosine to the bit; both within
    a few ulp of NumPy's (|angle| <= 3.1: tan(angle / 2) stays below 42, the rounding of
    1 + t^2 and its reciprocal a few ulp of the result)."""
    s, c, t, inv = (np.empty_like(angle) for _ in range(4))
    half_angle_sin_cos_into(angle, s, c, t, inv)
    s2, c2 = half_angle_sin_cos(angle)
    assert np.array_equal(s, s2) and np.array_equal(c, c2)
    np.testing.assert_allclose(s, np.sin(angle), rtol=0, atol=8e-16)
    np.testing.assert_allclose(c, np.cos(angle), rtol=0, atol=8e-16)
    only = angle.copy()
    half_angle_sin_cos_into(only, only, None, t, inv)  # the sine alone, over its own angle
    assert np.array_equal(only, s)

"""The Pacejka single-track reality (uqdrive.vehicle.realities) against textbook limits: the linear
bicycle's steady yaw rate, the tyre's saturation at its load-dependent peak, free-rolling wheels
without slip, and the longitudinal load transfer m a_x h / L under steady braking."""

import numpy as np
import pytest

from uqdrive.vehicle.realities import PacejkaCar, simulate_pacejka
from uqdrive.vehicle.realities.pacejka_single_track import PacejkaRHS
from uqdrive.vehicle.realities.pacejka_tyre import combined, cornering_stiffness, peak, pure_lateral, pure_longitudinal

V = 70 / 3.6
H = 0.002
CAR = PacejkaCar()
FREE = PacejkaCar(k_p=0.0, k_i=0.0)  # no drive torque


def _run(car, delta_of_t, t_end, torque=0.0, mu=1.0, m_load=100.0, l_f=1.55):
    n_steps = int(round(t_end / H))
    t_half = np.arange(2 * n_steps + 1) * H / 2
    zero = np.zeros((t_half.size, 1))
    return simulate_pacejka(car, np.array([mu]), np.array([m_load]), np.array([l_f]), delta_of_t(t_half), V, zero, zero, H, n_steps, 5,
                            torque=torque)


def test_the_tyres_formulas_golden_values():
    """By hand: D = mu F_z (1 + p_Dz dfz); K_y = K_y0 sin(2 atan(F_z / (q F_z0))) / sin(2 atan(1 / q))
    (K_y0 at F_z0, less than proportional above it); the pure forces' slopes at zero slip are K_y
    and K_x; the combined weights are cos(atan(B x)) of the other slip and 1 without it."""
    F0, K0, q = 4000.0, 80000.0, 1.6
    assert peak(6000.0, F0, 0.9, -0.15) == pytest.approx(0.9 * 6000.0 * (1 - 0.15 * 0.5), rel=1e-14)
    assert cornering_stiffness(F0, F0, K0, q) == pytest.approx(K0, rel=1e-14)
    K2 = cornering_stiffness(2 * F0, F0, K0, q)
    assert K2 == pytest.approx(K0 * np.sin(2 * np.arctan(2 / q)) / np.sin(2 * np.arctan(1 / q)), rel=1e-14) and K2 < 2 * K0
    a = 1e-7  # slope by a chord: the cubic term's error is (B a)^2 ~ 1e-11
    assert pure_lateral(a, 3000.0, K0, 1.9, 0.97) / a == pytest.approx(K0, rel=1e-9)
    assert pure_longitudinal(a, 3000.0, 20 * F0, 1.65) / a == pytest.approx(20 * F0, rel=1e-9)
    F_x, F_y = combined(100.0, 200.0, 0.1, 0.05)
    assert F_x == pytest.approx(100.0 * np.cos(np.arctan(12.0 * np.cos(np.arctan(1.0)) * 0.05)), rel=1e-14)
    assert F_y == pytest.approx(200.0 * np.cos(np.arctan(7.0 * np.cos(np.arctan(0.125)) * 0.1)), rel=1e-14)
    assert combined(100.0, 200.0, 0.0, 0.0) == (100.0, 200.0)


def test_the_lateral_force_saturates_at_the_load_dependent_peak():
    """Over slip angles to 0.5 rad the force's largest value is D = mu F_z (1 + p_Dz dfz) (C > 1:
    the curve reaches its peak; grid 1e-5 rad, so the peak is met to 1e-8 of D)."""
    alpha = np.linspace(0.0, 0.5, 50001)
    for F_z in (2000.0, 4000.0, 7000.0):
        D = peak(F_z, 4000.0, 1.1, -0.15)
        F = pure_lateral(alpha, D, cornering_stiffness(F_z, 4000.0, 80000.0, 1.6), 1.9, 0.97)
        assert F.max() == pytest.approx(D, rel=1e-8)


def test_the_steady_yaw_rate_at_small_lateral_acceleration_is_the_linear_bicycles():
    """0.3 deg steer held (a_y about 0.05 g): the yaw rate after 8 s is v delta / (L + K v^2),
    K = m / L (l_r / C_f - l_f / C_r), C_i = B_i C mu F_z0,i, within 1e-3 (what is left: the
    slip angles' arctan, the drive force's load transfer and combined slip, each below 3e-4)."""
    x, _ = _run(CAR, lambda t: np.deg2rad(0.3) * np.clip(t / 0.5, 0, 1), 8.0)
    m, L, l_f = CAR.m_base + 100.0, CAR.wheelbase, 1.55
    F0 = CAR.nominal_loads()[:, 0]
    C_f, C_r = CAR.B_f * CAR.C * F0[0], CAR.B_r * CAR.C * F0[1]
    K = m / L * ((L - l_f) / C_f - l_f / C_r)
    assert x[1, 0, -1] == pytest.approx(V * np.deg2rad(0.3) / (L + K * V * V), rel=1e-3)


def test_free_rolling_wheels_do_not_slip():
    """No drive torque through a 3 deg slalom (0.5 g): both wheels' slip ratio stays below 1e-4
    (the rear's drive slip with the controller, about 2e-3, would fail it)."""
    steer = lambda t: np.deg2rad(3.0) * np.sin(2 * np.pi * t / 4.0)  # noqa: E731
    x, a_y = _run(FREE, steer, 6.0)
    assert np.abs(a_y).max() > 4.0
    delta = steer(np.arange(x.shape[-1]) * 0.01)
    u_f = x[2] * np.cos(delta) + (x[3] + 1.55 * x[1]) * np.sin(delta)  # the front wheel's speed along its plane
    for row, u in ((5, u_f), (6, x[2])):
        assert np.abs(CAR.wheel_radius * x[row] / u - 1.0).max() < 1e-4
    driven, _ = _run(CAR, lambda t: np.deg2rad(3.0) * np.sin(2 * np.pi * t / 4.0), 6.0)
    assert np.abs(CAR.wheel_radius * driven[6] / driven[2] - 1.0).max() > 1e-3


def test_steady_braking_moves_m_ax_h_over_L_to_the_front_axle():
    """Braking torques on both axles, straight: after 2 s the front load exceeds its static one by
    -m a_x h / L, a_x from the speed's own derivative (within 1e-3: the derivative's central
    difference and the loop's three fixed-point steps)."""
    torque = np.array([[-900.0], [-600.0]])
    x, _ = _run(FREE, lambda t: np.zeros_like(t), 3.0, torque=torque)
    a_x = np.gradient(x[2, 0], 0.01)[-50]
    rhs = PacejkaRHS(FREE, np.array([1.0]), np.array([100.0]), np.array([1.55]), lambda j: 0.0, lambda j: 0.0, lambda j: 0.0, V, torque)
    F_z = rhs.forces(x[:, :, -50], 0)[2]
    m, L = FREE.m_base + 100.0, FREE.wheelbase
    assert a_x < -2.0
    assert F_z[0, 0] - m * FREE.g * (L - 1.55) / L == pytest.approx(-m * a_x * FREE.cg_height / L, rel=1e-3)

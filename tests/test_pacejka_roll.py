"""The multi-body-like reality (uqdrive.vehicle.realities.RollingCar) against its limits: the steady
roll angle is the roll gradient's, relaxed slip angles reach the kinematic ones, and the camber's
slip turns the front axle out of the turn and the rear into it."""

from functools import lru_cache

import numpy as np
import pytest

from uqdrive.vehicle.realities import PacejkaCar, RollingCar, simulate_pacejka

V, H = 70 / 3.6, 0.002
HELD = lambda t: np.deg2rad(1.0) * np.clip(t / 0.5, 0, 1)  # noqa: E731 - a held steer: 0.2 g


@lru_cache(maxsize=None)
def _run(car, t_end=5.0):
    n_steps = int(round(t_end / H))
    t_half = np.arange(2 * n_steps + 1) * H / 2
    zero = np.zeros((t_half.size, 1))
    return simulate_pacejka(car, np.array([1.0]), np.array([100.0]), np.array([1.55]), HELD(t_half), V, zero, zero, H, n_steps, 5)


def test_steady_roll_is_the_roll_gradients_and_the_relaxed_slip_the_kinematic():
    """After 5 s of a held steer: phi = R_phi a_y / g (1e-6 rad: the roll mode has settled, its
    envelope exp(-zeta omega t) below 1e-6), phi' = 0, and the lagged slip angles the kinematic
    ones (1e-6 rad); the roll moves 12 rows, the plain car's 8."""
    car = RollingCar()
    x, a_y = _run(car)
    assert x.shape[0] == 12
    assert a_y[0, -1] > 1.5 and x[10, 0, -1] == pytest.approx(car.roll_gradient * a_y[0, -1] / car.g, abs=1e-6)
    assert abs(x[11, 0, -1]) < 1e-6
    r, v_x, v_y = x[1, 0, -1], x[2, 0, -1], x[3, 0, -1]
    kinematic = [np.deg2rad(1.0) - np.arctan((v_y + 1.55 * r) / v_x), -np.arctan((v_y - (car.wheelbase - 1.55) * r) / v_x)]
    np.testing.assert_allclose(x[8:10, 0, -1], kinematic, atol=1e-6)


def test_relaxation_alone_changes_the_transient_not_the_steady_state():
    """Without camber the relaxing car's steady yaw rate is the plain car's (1e-6 relative); in the
    0.5 s ramp it lags it by more than 1 % of the steady value."""
    relaxing, plain = _run(RollingCar(camber_slip_front=0.0, camber_slip_rear=0.0))[0], _run(PacejkaCar())[0]
    assert relaxing[1, 0, -1] == pytest.approx(plain[1, 0, -1], rel=1e-6)
    assert (plain[1, 0, :60] - relaxing[1, 0, :60]).max() > 0.01 * plain[1, 0, -1]


@pytest.mark.parametrize("front, rear, sign", [(0.2, 0.0, -1), (0.0, 0.2, 1)])
def test_front_camber_understeers_and_rear_camber_oversteers(front, rear, sign):
    """Roll camber on the front axle alone lowers the steady yaw rate (it steers out of the turn) by
    more than 1 %; on the rear alone it raises it (the rear's force falls)."""
    yaw = _run(RollingCar(camber_slip_front=front, camber_slip_rear=rear))[0][1, 0, -1]
    none = _run(RollingCar(camber_slip_front=0.0, camber_slip_rear=0.0))[0][1, 0, -1]
    assert sign * (yaw - none) > 0.01 * none


def test_front_camber_slip_is_a_steer_that_follows_the_roll():
    """The front axle's roll slip (camber and kinematic roll steer, the roll_steering car's 0.30)
    acts as a steer angle -epsilon_f phi: at steady state the car turns as the car without roll
    slip steered by delta - epsilon_f phi_ss does. 1e-4 relative: the two differ only in the
    projection of the front force through delta (F_yf (1 - cos(epsilon_f phi)) ~ 1e-5 of it) and in
    the free-rolling front wheel's small F_xf sin(delta)."""
    steering = RollingCar(camber_slip_front=0.30, camber_slip_rear=0.0)
    x, _ = _run(steering)
    phi = x[10, 0, -1]
    n_steps = int(round(5.0 / H))
    t_half = np.arange(2 * n_steps + 1) * H / 2
    zero = np.zeros((t_half.size, 1))
    steer = HELD(t_half) * (1.0 - 0.30 * phi / np.deg2rad(1.0))
    y, _ = simulate_pacejka(RollingCar(camber_slip_front=0.0, camber_slip_rear=0.0), np.array([1.0]), np.array([100.0]), np.array([1.55]),
                            steer, V, zero, zero, H, n_steps, 5)
    assert phi > 0.005 and x[1, 0, -1] == pytest.approx(y[1, 0, -1], rel=1e-4)
    assert abs(x[1, 0, -1] - _run(RollingCar(camber_slip_front=0.0, camber_slip_rear=0.0))[0][1, 0, -1]) > 0.05 * y[1, 0, -1]

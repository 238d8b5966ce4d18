"""Combined slip: the longitudinal force that follows the speed takes lateral capacity by the
friction ellipse, per axle by the drive layout (uqdrive.vehicle.track_extended)."""

from dataclasses import replace

import numpy as np
import pytest

from uqdrive.settings import Settings
from uqdrive.vehicle import track_extended
from uqdrive.vehicle.effects import EFFECTS, VANISHES, ModelStructure, effect
from uqdrive.vehicle.single_track import VehicleParameters
from uqdrive.vehicle.track_extended import ExtendedSingleTrackRHS

V = 20.0
N = 30


def _rhs(config, s, n=N):
    p = VehicleParameters.from_settings(Settings.from_config(config), mu=np.full(n, 0.9), l_f=np.full(n, 1.55), v_c=V)
    return p, ExtendedSingleTrackRHS(p, s, 0.97, np.deg2rad([2.0, 3.0, 4.0]), np.zeros((3, n)), True, np.zeros(n))


def _states(n=N, seed=3):
    rng = np.random.default_rng(seed)
    return np.vstack([rng.normal(0, 0.1, n), rng.uniform(0.1, 0.4, n), rng.uniform(-0.04, 0.01, n), rng.normal(0, 1, n)])


def test_the_registry_entry_and_where_it_vanishes():
    """Two parameters (kappa, chi_d), in bounds, kappa vanishing at 0; the structure then needs the
    chassis right-hand side and numerical integration, at kappa = 0 it is the baseline's."""
    e = EFFECTS["combined_slip"]
    assert e.parameters == ("kappa", "chi_d") and e.units == ("-", "-") and VANISHES["combined_slip"] == ("kappa", 0.0)
    s = effect("combined_slip").augment(ModelStructure(), [1.0, 0.0])
    assert s.combined_slip == 1.0 and s.drive_share_front == 0.0 and s.nonlinear and s.uses_chassis
    off = effect("combined_slip").augment(ModelStructure(), [0.0, 0.3])
    assert not off.nonlinear and not off.uses_chassis


@pytest.mark.parametrize("tyre", ["linear", "magic_formula"])
@pytest.mark.parametrize("v_dot, chi_d", [(3.0, 0.0), (3.0, 1.0), (-4.0, 0.0)])
def test_each_axle_keeps_the_friction_ellipses_share_of_its_lateral_force(config, tyre, v_dot, chi_d, monkeypatch):
    """Accelerating (3 m/s^2, rear or front drive) or braking (4 m/s^2, the brakes by the static
    loads) through a turn: each axle's lateral force is the one without combined slip times
    sqrt(1 - (F_x,i / (mu F_z,i))^2), F_x = m a_x, a_x = v' cos(beta) - tan(beta) (a_y - v' sin(beta)),
    a_y = (F_f cos delta + F_r) / m at the forces themselves (the loop to rounding: 1e-10 of the
    force). The axle carrying no driving force keeps its force exactly; removed (kappa 0) or
    with the force's share growing the capacity (1 + ...), the golden value misses."""
    monkeypatch.setattr(track_extended, "LOAD_NEWTON_STEPS", 12)
    base = ModelStructure(tyre=tyre, tyre_curvature=0.97 if tyre == "magic_formula" else None)
    s = effect("combined_slip").augment(base, [1.0, chi_d])
    p, rhs = _rhs(config, s)
    _, free = _rhs(config, replace(s, combined_slip=0.0))
    x = _states()
    _, delta, F = rhs._forces(x, 1, V, v_dot)
    _, _, F0 = free._forces(x, 1, V, v_dot)
    front = np.cos(delta) if tyre == "magic_formula" else 1.0
    a_y = (F[0] * front + F[1]) / p.m
    F_x = p.m * (v_dot * np.cos(x[2]) - np.tan(x[2]) * (a_y - v_dot * np.sin(x[2])))
    static = np.stack([np.broadcast_to(p.F_fz, (N,)), np.broadcast_to(p.F_rz, (N,))])
    share = np.where(F_x > 0, np.array([[chi_d], [1.0 - chi_d]]), static / static.sum(axis=0))
    kept = np.sqrt(1.0 - (share * F_x / (0.9 * static)) ** 2)
    np.testing.assert_allclose(F, F0 * kept, rtol=0, atol=1e-10 * np.abs(F0).max())
    lost = 1.0 - kept.min()
    assert lost > 0.01  # the term matters here: 1 % of an axle's force at least
    if v_dot > 0:
        driven = 0 if chi_d == 1.0 else 1
        np.testing.assert_array_equal(F[1 - driven], F0[1 - driven])
        assert np.all(np.abs(F[driven]) < np.abs(F0[driven]))


def test_front_drive_understeers_and_rear_drive_oversteers(config):
    """Accelerating out of a left turn (3 m/s^2): front drive lowers the front axle's force, the yaw
    acceleration falls against no combined slip; rear drive lowers the rear axle's, it rises. A
    swapped layout or a flipped sign reverses both."""
    x = _states()
    yaw = {}
    for name, s in [("none", ModelStructure(combined_slip=0.0)), ("front", effect("combined_slip").augment(ModelStructure(), [1.0, 1.0])),
                    ("rear", effect("combined_slip").augment(ModelStructure(), [1.0, 0.0]))]:
        _, rhs = _rhs(config, s)
        rhs.speed_half = (np.full(3, V), np.full(3, 3.0))
        out = np.empty((rhs.n_states, N))
        rhs(x, 1, out)
        yaw[name] = out[1]
    turning = x[1] > 0
    assert np.all(yaw["front"][turning] < yaw["none"][turning]) and np.all(yaw["rear"][turning] > yaw["none"][turning])


def test_at_held_speed_straight_ahead_nothing_changes(config):
    """beta = 0 and v' = 0: no longitudinal force, the model is the one without combined slip to the bit."""
    x = _states()
    x[2] = 0.0
    outs = []
    for s in (effect("combined_slip").augment(ModelStructure(), [1.0, 0.5]), ModelStructure(pitch_height=0.0)):
        _, rhs = _rhs(config, s)
        if not rhs.slipping:
            _, rhs = _rhs(config, replace(s, combined_slip=1e-300))
        out = np.empty((4, N))
        rhs(x, 1, out)
        outs.append(out)
    np.testing.assert_array_equal(outs[0], outs[1])


def test_braking_through_a_slalom_the_simulator_takes_the_term_batched_as_alone(config):
    """Braking 22 -> 16 m/s through a 3 deg slalom: rear drive with the brakes by the static loads
    changes the yaw rate by more than 0.5 % of its range against no combined slip; two structures
    simulated in one batch (per-realisation fields) give each the numbers it gets alone."""
    from uqdrive.vehicle.augmented import AugmentedSimulator

    t = np.arange(301) * 0.01
    delta = np.deg2rad(3.0) * np.sin(2 * np.pi * t / 1.5)
    speed = 22.0 - 2.0 * t
    sim = AugmentedSimulator.drawn(Settings.from_config(config), t, delta, float(np.mean(speed)), 4, np.random.default_rng(0), speed=speed)
    theta = [0.8, 0.0, 1.55, 0.0, 0.0, 0.0]
    slip = effect("combined_slip").augment(ModelStructure(), [1.0, 0.0])
    held = effect("combined_slip").augment(ModelStructure(), [0.5, 1.0])
    with_slip, without = sim.simulate(theta, slip), sim.simulate(theta, ModelStructure())
    span = np.ptp(without[1])
    assert np.abs(with_slip[1] - without[1]).max() > 5e-3 * span
    both = sim.simulate_many([theta, theta], [slip, held])
    np.testing.assert_array_equal(both[0], with_slip)
    np.testing.assert_array_equal(both[1], sim.simulate(theta, held))

"""The load-sensitive tyre: axle stiffness and peak that depart from proportionality to the load
the longitudinal acceleration moves (uqdrive.vehicle.track_extended)."""

import copy
from dataclasses import replace

import numpy as np
import pytest

from uqdrive.settings import Settings
from uqdrive.vehicle import track_extended
from uqdrive.vehicle.effects import EFFECTS, VANISHES, ModelStructure, effect
from uqdrive.vehicle.single_track import VehicleParameters, curvature_argument
from uqdrive.vehicle.track_extended import ExtendedSingleTrackRHS

V, N, H_CG = 20.0, 30, 0.55
Q, P_DZ = -0.5, -0.2


def _rhs(config, s, reference=None, m_load=None):
    m_load = np.full(N, 100.0) if m_load is None else m_load
    p = VehicleParameters.from_settings(Settings.from_config(config), mu=np.full(N, 0.9), l_f=np.full(N, 1.55), m_load=m_load, v_c=V)
    rhs = ExtendedSingleTrackRHS(p, s, 0.97, np.deg2rad([2.0, 3.0, 4.0]), np.zeros((3, N)), True, np.zeros(N), tyre_load_height=H_CG,
                                 reference_loads=reference)
    return p, rhs


def _states(seed=3):
    rng = np.random.default_rng(seed)
    return np.vstack([rng.normal(0, 0.1, N), rng.uniform(0.1, 0.4, N), rng.uniform(-0.04, 0.01, N), rng.normal(0, 1, N)])


def _tyre(tyre):
    return ModelStructure(tyre=tyre, tyre_curvature=0.97 if tyre == "magic_formula" else None)


def test_the_registry_entry_and_where_it_vanishes():
    """Two parameters (q, p_Dz), dimensionless, q vanishing at 0; at q = p_Dz = 0 the structure is
    the baseline's (no chassis term, linear), otherwise it needs the chassis right-hand side."""
    e = EFFECTS["load_sensitive_tyre"]
    assert e.parameters == ("q", "p_Dz") and e.units == ("-", "-") and VANISHES["load_sensitive_tyre"] == ("q", 0.0)
    assert all(lo < st < hi for (lo, hi), st in zip(e.bounds, e.start))
    s = effect("load_sensitive_tyre").augment(ModelStructure(), [Q, P_DZ])
    assert s.stiffness_load_sensitivity == Q and s.peak_load_sensitivity == P_DZ and s.nonlinear and s.uses_chassis
    off = effect("load_sensitive_tyre").augment(ModelStructure(), [0.0, 0.0])
    assert not off.nonlinear and not off.uses_chassis
    assert effect("load_sensitive_tyre").augment(ModelStructure(), [0.0, -0.1]).uses_chassis


@pytest.mark.parametrize("tyre", ["linear", "magic_formula"])
@pytest.mark.parametrize("v_dot", [-4.0, 3.0])
def test_each_axles_force_by_hand_from_its_load_change(config, tyre, v_dot, monkeypatch):
    """Braking (4 m/s^2) or accelerating (3 m/s^2) through a turn, each realisation's own static
    loads the reference: dfz_i = -+ m a_x h / (L F_z0,i), a_x = v' cos(beta) - tan(beta) (a_y -
    v' sin(beta)) at the forces themselves (the loop to rounding: 1e-10 of the force). Linear
    tyre: F_i = c_i alpha_i (1 + q dfz_i); Magic Formula: D_i (1 + p_Dz dfz_i) sin(C atan(curv(B_i
    (1 + q dfz_i) / (1 + p_Dz dfz_i) alpha_i))). Removed (q = p_Dz = 0) or with the sign of dfz
    flipped, the golden value misses by more than 1 % of an axle's force."""
    monkeypatch.setattr(track_extended, "LOAD_NEWTON_STEPS", 12)
    s = effect("load_sensitive_tyre").augment(_tyre(tyre), [Q, P_DZ])
    p, rhs = _rhs(config, s)
    x = _states()
    alpha, delta = rhs.steady_slip(x, 1, V)
    _, d, F = rhs._forces(x, 1, V, v_dot)
    front = np.cos(d) if tyre == "magic_formula" else 1.0
    a_y = (F[0] * front + F[1]) / p.m
    a_x = v_dot * np.cos(x[2]) - np.tan(x[2]) * (a_y - v_dot * np.sin(x[2]))
    shift = p.m * a_x * H_CG / p.wheelbase
    static = np.stack([np.broadcast_to(p.F_fz, (N,)), np.broadcast_to(p.F_rz, (N,))])

    def by_hand(sign):
        dfz = sign * np.stack([-shift, shift]) / static
        B = np.array([[p.c_Sf], [p.c_Sr]]) * (1 + Q * dfz)
        if tyre == "linear":
            return 0.9 * static * B * p.C * alpha
        B = B / (1 + P_DZ * dfz)
        return 0.9 * static * (1 + P_DZ * dfz) * np.sin(p.C * np.arctan(curvature_argument(B * alpha, 0.97)))

    scale = np.abs(F).max()
    np.testing.assert_allclose(F, by_hand(1.0), rtol=0, atol=1e-10 * scale)
    _, _, F_base = _rhs(config, _tyre(tyre))[1]._forces(x, 1, V, v_dot)
    for wrong in (F_base, by_hand(-1.0)):
        assert np.abs(F - wrong).max() > 0.01 * scale


def test_braking_in_a_turn_understeers_with_a_degressive_stiffness(config):
    """Braking (4 m/s^2) in a left turn loads the front axle: with q < 0 its stiffness gains less
    than its load, the yaw acceleration falls against q = 0; q > 0 (progressive) raises it."""
    x = _states()
    yaw = {}
    for q in (-0.5, 0.0, 0.5):
        s = effect("load_sensitive_tyre").augment(ModelStructure(), [q, 0.0]) if q else ModelStructure()
        _, rhs = _rhs(config, s if q else replace(s, peak_load_sensitivity=1e-300))
        rhs.speed_half = (np.full(3, V), np.full(3, -4.0))
        out = np.empty((4, N))
        rhs(x, 1, out)
        yaw[q] = out[1]
    turning = x[1] > 0
    assert np.all(yaw[-0.5][turning] < yaw[0.0][turning]) and np.all(yaw[0.5][turning] > yaw[0.0][turning])


def test_a_heavier_realisation_against_the_nominal_cars_loads(config):
    """At held speed straight ahead with no side slip the loads are static; against the nominal
    car's loads (m_load 100 kg) a realisation 300 kg heavier has dfz = 300 / (m_base + 100) on both
    axles, its linear force c alpha (1 + q dfz); the nominal realisation's force is the baseline's to the bit."""
    m_load = np.where(np.arange(N) % 2, 400.0, 100.0)
    nominal = VehicleParameters.from_settings(Settings.from_config(config), m_load=100.0, l_f=1.55)
    x = _states()
    x[2] = 0.0
    s = effect("load_sensitive_tyre").augment(ModelStructure(), [Q, P_DZ])
    _, rhs = _rhs(config, s, reference=(nominal.F_fz, float(nominal.F_rz)), m_load=m_load)
    _, base = _rhs(config, replace(s, stiffness_load_sensitivity=0.0, peak_load_sensitivity=0.0, pitch_height=1e-300), m_load=m_load)
    F = rhs._forces(x, 1, V, 0.0)[2]
    F0 = base._forces(x, 1, V, 0.0)[2]
    heavy = m_load > 100.0
    np.testing.assert_array_equal(F[:, ~heavy], F0[:, ~heavy])
    np.testing.assert_allclose(F[:, heavy], F0[:, heavy] * (1 + Q * 300.0 / (nominal.m_base + 100.0)), rtol=1e-12)


def test_straight_ahead_at_held_speed_nothing_changes(config):
    """beta = 0 and v' = 0 with the realisations' own loads the reference: dfz = 0, the model is the
    baseline's to the bit."""
    x = _states()
    x[2] = 0.0
    outs = []
    for s in (effect("load_sensitive_tyre").augment(ModelStructure(), [Q, P_DZ]), ModelStructure(pitch_height=1e-300)):
        _, rhs = _rhs(config, s)
        out = np.empty((4, N))
        rhs(x, 1, out)
        outs.append(out)
    np.testing.assert_array_equal(outs[0], outs[1])


def test_braking_through_a_slalom_batched_as_alone(config):
    """Braking 22 -> 16 m/s through a 3 deg slalom: the term changes the yaw rate by more than
    0.5 % of its range; two structures in one batch give each the numbers it gets alone."""
    from uqdrive.vehicle.augmented import AugmentedSimulator

    cfg = copy.deepcopy(config)
    cfg["vehicle"]["cg_height"] = H_CG
    t = np.arange(301) * 0.01
    delta = np.deg2rad(3.0) * np.sin(2 * np.pi * t / 1.5)
    sim = AugmentedSimulator.drawn(Settings.from_config(cfg), t, delta, 19.0, 4, np.random.default_rng(0), speed=22.0 - 2.0 * t)
    theta = [0.8, 0.0, 1.55, 0.0, 0.0, 0.0]
    a = effect("load_sensitive_tyre").augment(ModelStructure(), [-0.8, 0.0])
    b = effect("load_sensitive_tyre").augment(ModelStructure(), [0.4, -0.1])
    with_a, without = sim.simulate(theta, a), sim.simulate(theta, ModelStructure())
    assert np.abs(with_a[1] - without[1]).max() > 5e-3 * np.ptp(without[1])
    both = sim.simulate_many([theta, theta], [a, b])
    np.testing.assert_array_equal(both[0], with_a)
    np.testing.assert_array_equal(both[1], sim.simulate(theta, b))

"""The chassis right-hand side's compiled arithmetic (vehicle/dynamics/fused_chassis.py, on the
linear tyre fused_linear.py) gives the NumPy path's numbers bit for bit, its rates and the lateral
acceleration a_y, on every term it serves with and without its neighbours, and the chassis models
it does not serve take the NumPy path."""

import itertools
from dataclasses import replace

import numpy as np
import pytest

from uqdrive.config import load_config
from uqdrive.numerics.integrate import rk4_fixed_step_into
from uqdrive.settings import Settings
from uqdrive.vehicle import track_extended
from uqdrive.vehicle.effects import ModelStructure, effect
from uqdrive.vehicle.single_track import VehicleParameters

SETTINGS = Settings.from_config(load_config(None))
V, J = 70.0 / 3.6, 41  # m/s; half steps of the tabulated inputs
H, T_W = 0.55, 1.6
VALUES = {"lateral_load_transfer": [0.6, -0.4], "longitudinal_load_transfer": [0.55], "combined_slip": [0.8, 0.4],
          "tyre_relaxation": [0.4], "roll_steer": [0.5, 1.7, 0.4], "road_bank": [0.3], "lateral_kinematics": [0.7],
          "compliance_steer": [0.4], "load_sensitive_tyre": [0.5, -0.2]}
CHASSIS = ("tyre_relaxation", "roll_steer", "lateral_load_transfer", "longitudinal_load_transfer", "combined_slip")
#: Each chassis term alone, in pairs and the loads' three together, with the terms of the
#: kinematics (a bank, the course weight) on the side.
SETS = [()] + [(c,) for c in CHASSIS] + list(itertools.combinations(CHASSIS, 2)) + [CHASSIS[2:], CHASSIS]
#: Compliance steer on the Magic Formula (its own Newton loop through the tyre's sine), served
#: without relaxation: alone and beside the roll steer on static loads, beside each term that moves
#: the loads (the yield at each step of the loads' loop), and with all of them.
YIELDING = ([("compliance_steer",), ("compliance_steer", "roll_steer")] + [("compliance_steer", c) for c in CHASSIS[2:]]
            + [("compliance_steer", "roll_steer") + CHASSIS[2:]])
#: The load-sensitive tyre on the Magic Formula (its curve anew at each Newton step's loads): alone,
#: beside each chassis term, and with all of them.
SENSITIVE = [("load_sensitive_tyre",)] + [("load_sensitive_tyre", c) for c in CHASSIS] + [("load_sensitive_tyre",) + CHASSIS]
#: On the linear tyre: relaxation, roll steer and compliance steer alone, in pairs and together,
#: and each term that moves the loads alone, beside relaxation or compliance steer, and with all.
LINEAR = ("tyre_relaxation", "roll_steer", "compliance_steer")
LOADS = ("lateral_load_transfer", "longitudinal_load_transfer", "combined_slip", "load_sensitive_tyre")
LINEAR_SETS = ([()] + [(c,) for c in LINEAR + LOADS] + list(itertools.combinations(LINEAR, 2))
               + [(c, load) for load in LOADS for c in ("tyre_relaxation", "compliance_steer")] + [LINEAR, LINEAR + LOADS])


def _structure(terms, per_run=None, linear=False):
    """The Magic-Formula model (``linear``: the LST's) with ``terms``; ``per_run`` (a seeded
    Generator): the relaxation length (a quarter of them 0), roll steer, course weight and bank
    drawn per realisation."""
    s = ModelStructure() if linear else effect("tyre_saturation").augment(ModelStructure(), [0.97])
    for name in terms:
        s = effect(name).augment(s, VALUES[name])
    if per_run is not None:
        n = 53
        more = {"course_weight": per_run.uniform(0.2, 1.0, n), "lateral_acceleration": per_run.normal(0.3, 0.1, n)}
        if "tyre_relaxation" in terms:
            more["relaxation_length"] = np.where(per_run.random(n) < 0.25, 0.0, per_run.uniform(0.2, 0.6, n))
        if "roll_steer" in terms:
            more["roll_steer"] = per_run.uniform(0.2, 0.8, n)
        if "compliance_steer" in terms:
            more["compliance_steer"] = per_run.uniform(-8.0, 0.6, n)  # about half of them at the yield's floor on the linear tyre
        s = replace(s, **more)
    return s


def _rhs(fused: bool, s, n=53, speed=False, per_run=False, seed=7):
    """A chassis right-hand side of n realisations from one seed: with ``per_run`` the steering per
    realisation, E and on the Magic Formula B_f, B_r and C per realisation (a pass of several tyre shapes) and the wind's yaw
    moment a constant M_w (else one steering table, one shape and M_c F_w); ``speed``, a braking speed profile."""
    rng = np.random.default_rng(seed)
    p = VehicleParameters.from_settings(SETTINGS, mu=rng.uniform(0.6, 1.0, n), l_f=rng.uniform(1.4, 1.7, n), m_load=rng.normal(100, 30, n), v_c=V)
    delta = np.deg2rad(5.0) * np.sin(np.linspace(0.0, 3.0, J))
    if per_run:
        delta = delta[:, None] * rng.uniform(0.5, 1.5, n)
    speed_half = (np.linspace(V, V - 4.0, J), np.full(J, -3.0)) if speed else None
    E = rng.uniform(0.5, 1.0, n) if per_run else 0.97
    if per_run and s.tyre == "magic_formula":
        shapes = np.random.default_rng(seed + 1)
        p = replace(p, c_Sf=p.c_Sf * shapes.uniform(0.9, 1.1, n), c_Sr=p.c_Sr * shapes.uniform(0.9, 1.1, n), C=shapes.uniform(1.5, 1.9, n))
    track_extended.FUSED = fused
    try:
        return track_extended.ExtendedSingleTrackRHS(p, s, E, delta, rng.uniform(-300.0, 300.0, (J, n)), not per_run, rng.normal(0.0, 2.0, n),
                                                     H, T_W, speed_half=speed_half, tyre_load_height=H)
    finally:
        track_extended.FUSED = True


def _states(rhs, rng, n=53):
    """States with large yaw rates and side slips (tyres past their peak, wheels lifting) and
    courses either side of the half-angle sine's 3 rad bound."""
    return np.vstack([rng.normal(0, 1.5, n), rng.normal(0, 0.6, n), rng.normal(0, 0.15, n), rng.normal(0, 1, n)]
                     + [rng.normal(0, 0.05, n) for _ in range(rhs.n_states - 4)])


def _rates(rhs, x, steps=(0, 1, 2)):
    out = np.empty((len(steps), rhs.n_states, x.shape[1]))
    for k, j in enumerate(steps):
        rhs(x, j, out[k])
    return out


def _accelerations(rhs, x, steps=(0, 1, 2)):
    """a_y (m/s^2) of ``x`` at the half steps: what the recorded a_y channel reads."""
    return np.stack([rhs.lateral_acceleration(x, j) for j in steps])


@pytest.mark.parametrize("per_run", [False, True], ids=["numbers", "per-run"])
@pytest.mark.parametrize("speed", [False, True], ids=["held", "braking"])
@pytest.mark.parametrize("terms", SETS + YIELDING + SENSITIVE, ids=lambda t: "+".join(t) or "tyre")
def test_the_compiled_chassis_rates_are_the_numpy_rates_bit_for_bit(terms, speed, per_run):
    """Each term alone, in pairs and together, at held speed and braking, with numbers or per-realisation
    inputs and constants (relaxation lengths of zero among them): the same doubles at three half
    steps, the compiled path taken."""
    extra = ("road_bank", "lateral_kinematics") if per_run else ()
    s = _structure(terms + extra, np.random.default_rng(2) if per_run else None)
    reference, fused = _rhs(False, s, speed=speed, per_run=per_run), _rhs(True, s, speed=speed, per_run=per_run)
    x = _states(reference, np.random.default_rng(3))
    expected = _rates(reference, x)
    got = _rates(fused, x)
    assert fused.fused and not reference.fused
    assert np.all(np.isfinite(expected))
    np.testing.assert_array_equal(got, expected)
    np.testing.assert_array_equal(_accelerations(fused, x), _accelerations(reference, x))


@pytest.mark.parametrize("per_run", [False, True], ids=["numbers", "per-run"])
@pytest.mark.parametrize("speed", [False, True], ids=["held", "braking"])
@pytest.mark.parametrize("terms", LINEAR_SETS, ids=lambda t: "+".join(t) or "tyre")
def test_the_compiled_linear_chassis_rates_are_the_numpy_rates_bit_for_bit(terms, speed, per_run):
    """On the linear tyre (the LST's kinematics, its course linear, with per-realisation inputs the
    exact course of lateral_kinematics and a bank): each term alone, in pairs and together, on
    static loads and on loads that follow the tyres' force, the same doubles at three half steps,
    the compiled path taken."""
    extra = ("road_bank", "lateral_kinematics") if per_run else ()
    s = _structure(terms + extra, np.random.default_rng(2) if per_run else None, linear=True)
    reference, fused = _rhs(False, s, speed=speed, per_run=per_run), _rhs(True, s, speed=speed, per_run=per_run)
    x = _states(reference, np.random.default_rng(3))
    x[0] = np.clip(x[0], -2.5, 2.5)  # the exact course within the half-angle sine's bound
    expected, got = _rates(reference, x), _rates(fused, x)
    assert fused.fused and not reference.fused
    assert np.all(np.isfinite(expected))
    np.testing.assert_array_equal(got, expected)
    np.testing.assert_array_equal(_accelerations(fused, x), _accelerations(reference, x))


@pytest.mark.parametrize("linear", [False, True], ids=["magic formula", "linear tyre"])
def test_the_course_takes_numpys_sine_where_an_angle_is_past_3_rad_or_nan(linear):
    """The course row's two sines (the half angle's within 3 rad, NumPy's beyond; on the linear tyre
    lateral_kinematics' exact course): all within the bound, one past it, one NaN state (its own
    rates NaN, the rest as NumPy's)."""
    terms = ("compliance_steer", "lateral_kinematics") if linear else ("tyre_relaxation", "lateral_load_transfer")
    s = _structure(terms, linear=linear)
    reference, fused = _rhs(False, s), _rhs(True, s)
    x = _states(reference, np.random.default_rng(4))
    for psi in (0.5, 3.5, np.nan):
        x[0] = np.clip(x[0], -2.5, 2.5)
        x[0, 7] = psi
        np.testing.assert_array_equal(_rates(fused, x), _rates(reference, x))
    assert fused.fused


def test_an_ensemble_integrated_with_the_compiled_chassis_rates_is_the_numpy_ensemble_bit_for_bit():
    """Relaxation, roll steer and the loads' loop (on the linear tyre with compliance steer) over 20
    RK4 steps from rest along the steering table."""
    for s in (_structure(("tyre_relaxation", "roll_steer", "lateral_load_transfer")),
              _structure(LINEAR + ("lateral_load_transfer",), linear=True)):
        runs = [rk4_fixed_step_into(_rhs(fused, s, speed=True, per_run=True), np.zeros((8, 53)), 0.01, 20, 1) for fused in (False, True)]
        assert np.abs(runs[0][-1, 1]).max() > 1e-3  # the car turned
        np.testing.assert_array_equal(runs[1], runs[0])


@pytest.mark.parametrize("case", ["linear tyre, loop in NumPy", "compliance steer, relaxing", "compliance steer, load transfer, loop in NumPy",
                                  "load-sensitive tyre, compliance steer", "load-sensitive tyre, loop in NumPy", "loop in NumPy",
                                  "per-run B, linear tyre", "switched off"])
def test_chassis_models_the_compiled_rates_do_not_serve_take_the_numpy_path(case, monkeypatch):
    """Yielding wheels on the Magic Formula beside relaxation or beside the load-sensitive
    stiffness, a loads' loop kept in NumPy (on either tyre, the load-sensitive one's and the
    yielding wheels' included), per-realisation stiffness factors on the linear tyre and the switch
    keep the NumPy path, with its numbers."""
    terms = {"compliance steer, relaxing": ("compliance_steer", "tyre_relaxation"),
             "compliance steer, load transfer, loop in NumPy": ("compliance_steer", "lateral_load_transfer"),
             "load-sensitive tyre, compliance steer": ("load_sensitive_tyre", "compliance_steer"),
             "load-sensitive tyre, loop in NumPy": ("load_sensitive_tyre",)}.get(case, ("tyre_relaxation",))
    s = _structure(terms)
    if case == "linear tyre, loop in NumPy":
        s = _structure(("lateral_load_transfer",), linear=True)
        monkeypatch.setattr(track_extended, "COMPILED_LOOP", False)
    if case in ("loop in NumPy", "load-sensitive tyre, loop in NumPy", "compliance steer, load transfer, loop in NumPy"):
        s = s if case != "loop in NumPy" else _structure(("lateral_load_transfer",))
        monkeypatch.setattr(track_extended, "COMPILED_LOOP", False)
    rhs = _rhs(case != "switched off", s)
    if case == "per-run B, linear tyre":
        rhs = _rhs(True, _structure(("roll_steer",), linear=True))
        rhs.B = np.array([[10.0], [11.0]]) * np.ones(53)
    x = _states(rhs, np.random.default_rng(5))
    _rates(rhs, x, (1,))
    assert not rhs.fused

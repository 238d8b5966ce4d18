"""The compiled loads-forces loop (uqdrive.vehicle.dynamics.load_newton) against the NumPy loop of the chassis
right-hand side: the same numbers to the bit for every term it serves, and the NumPy loop kept where
the loop is not arithmetic alone."""

from __future__ import annotations

import re

import numpy as np
import pytest
from numba import njit

from uqdrive.settings import Settings
from uqdrive.vehicle import track_extended
from uqdrive.vehicle.dynamics.load_newton import ROWS, loads_step, newton_loop
from uqdrive.vehicle.effects import ModelStructure, effect
from uqdrive.vehicle.single_track import VehicleParameters

V = 70.0 / 3.6
H, T_W = 0.55, 1.6
TERMS = {"lateral_load_transfer": [0.6, -0.4], "longitudinal_load_transfer": [0.55], "combined_slip": [0.8, 0.4],
         "load_sensitive_tyre": [0.5, -0.2], "compliance_steer": [0.4], "tyre_relaxation": [0.4]}

#: Every term the compiled loop branches on, each with and without its neighbours, on both tyres
#: (a combination compiles in about 2 s on a cold cache: a covering set, not every product).
CASES = [
    ("linear", ("lateral_load_transfer",)),
    ("linear", ("longitudinal_load_transfer", "combined_slip")),
    ("linear", ("lateral_load_transfer", "load_sensitive_tyre", "compliance_steer")),
    ("linear", ("longitudinal_load_transfer", "compliance_steer", "tyre_relaxation")),
    ("linear", ("combined_slip", "load_sensitive_tyre", "tyre_relaxation")),
    ("magic_formula", ("lateral_load_transfer", "longitudinal_load_transfer")),
    ("magic_formula", ("combined_slip", "tyre_relaxation")),
]


def _structure(tyre, terms):
    s = effect("tyre_saturation").augment(ModelStructure(), [0.97]) if tyre == "magic_formula" else ModelStructure()
    for name in terms:
        s = effect(name).augment(s, TERMS[name])
    return s


def _rhs(config, s, rng, n, speed):
    p = VehicleParameters.from_settings(Settings.from_config(config), mu=rng.uniform(0.6, 1.0, n), l_f=rng.uniform(1.4, 1.7, n), v_c=V)
    F_w = rng.uniform(-300.0, 300.0, (3, n))
    return lambda: track_extended.ExtendedSingleTrackRHS(p, s, 0.97, np.deg2rad([2.0, 4.0, 6.0]), F_w, True, np.zeros(n), H, T_W,
                                                         speed_half=speed)


def _derivatives(make, x, monkeypatch, compiled):
    monkeypatch.setattr(track_extended, "COMPILED_LOOP", compiled)
    rhs = make()
    out = np.empty((rhs.n_states, x.shape[1]))
    rhs(x, 1, out)
    return out, rhs._compiled_loop, rhs.lateral_acceleration(x, 2)


@pytest.mark.parametrize("speed", [None, (np.full(3, V), np.array([0.0, -4.0, 2.5]))], ids=["held", "braking"])
@pytest.mark.parametrize("tyre, terms", CASES, ids=["+".join((t,) + c) for t, c in CASES])
def test_the_compiled_loop_gives_the_numpy_loops_numbers(config, tyre, terms, speed, monkeypatch):
    """dx/dt and a_y at random states, wheels lifting and tyres past their peak among them
    (large yaw rates and side slips): equal to the bit, the compiled loop taken."""
    rng = np.random.default_rng(7)
    n = 257  # odd: the vectorised loop's remainder too
    s = _structure(tyre, terms)
    make = _rhs(config, s, rng, n, speed)
    states = make().n_states
    x = np.vstack([rng.normal(0, 0.2, n), rng.normal(0, 0.6, n), rng.normal(0, 0.08, n), rng.normal(0, 1, n)]
                  + [rng.normal(0, 0.05, n) for _ in range(states - 4)])
    reference, used, a_y = _derivatives(make, x, monkeypatch, compiled=False)
    compiled, used_compiled, a_y_compiled = _derivatives(make, x, monkeypatch, compiled=True)
    assert not used and used_compiled
    assert np.all(np.isfinite(reference))
    np.testing.assert_array_equal(compiled, reference)
    np.testing.assert_array_equal(a_y_compiled, a_y)


def test_the_compiled_loop_where_wheels_lift(config, monkeypatch):
    """The case the per-wheel clamps exist for: from a light turn to about 1.8 g of lateral force the inner wheels of
    a tall car (h 1.2 m) lift; the compiled loop's forces equal the NumPy loop's, and with 12 steps
    they are the forces of the loads their own sum makes (the loop's fixed point, 1e-9 of the force)."""
    rng = np.random.default_rng(3)
    n = 64
    s = _structure("linear", ("lateral_load_transfer",))
    p = VehicleParameters.from_settings(Settings.from_config(config), mu=np.full(n, 1.0), l_f=np.full(n, 1.55), v_c=V)
    x = np.vstack([np.zeros(n), rng.uniform(0.02, 0.9, n), rng.uniform(-0.1, -0.02, n), np.zeros(n)])

    def forces(compiled, steps=track_extended.LOAD_NEWTON_STEPS):
        monkeypatch.setattr(track_extended, "COMPILED_LOOP", compiled)
        monkeypatch.setattr(track_extended, "LOAD_NEWTON_STEPS", steps)
        rhs = track_extended.ExtendedSingleTrackRHS(p, s, 0.97, np.deg2rad([2.0, 4.0, 6.0]), np.zeros((3, n)), True, np.zeros(n), 1.2, T_W)
        assert rhs._compiled_loop == compiled
        return rhs, rhs._forces(x, 1, V, 0.0)

    rhs, (q, _, F) = forces(True)
    np.testing.assert_array_equal(F, forces(False)[1][2])
    inner = 0.5 * rhs.static - rhs.lateral_arm * (F[0] + F[1])  # the inner wheels' loads before the clamp
    assert np.any(inner < 0) and np.any(inner > 0)  # lifted and loaded wheels both
    rhs, (q, _, F) = forces(True, 12)
    np.testing.assert_array_equal(F, forces(False, 12)[1][2])
    np.testing.assert_allclose(F, rhs.tyre_forces(q, F[0] + F[1], x[2]), rtol=0, atol=1e-9 * np.abs(F).max())


@pytest.mark.parametrize("terms", [("lateral_load_transfer", "compliance_steer"), ("load_sensitive_tyre",)])
def test_the_magic_formula_loop_stays_numpy_where_it_is_not_arithmetic(config, terms):
    """On the Magic Formula, yielding wheels (their own Newton loop through the tyre's sine) and the
    load-sensitive stiffness (the curve recomputed per step) keep the NumPy loop; the linear tyre with
    the same terms takes the compiled one."""
    rng = np.random.default_rng(1)
    assert not _rhs(config, _structure("magic_formula", terms), rng, 8, None)()._compiled_loop
    assert _rhs(config, _structure("linear", terms), rng, 8, None)()._compiled_loop
    assert not _rhs(config, _structure("magic_formula", ("tyre_relaxation",)), rng, 8, None)()._compiled_loop  # no loads: no loop


@pytest.mark.parametrize("tyre", ["linear", "magic_formula"])
def test_the_compiled_loop_where_an_axle_is_unloaded_and_where_a_state_is_nan(config, tyre, monkeypatch):
    """Braking and driving at 0.95 g with the mass 2.5 m up: the pitch takes more than its static
    load from one axle (its load clamped at zero) and the friction ellipse draws on the braking and
    the driving shares; two realisations hold NaN states. The compiled loop (its Newton steps and
    final pass each a loop of its own) gives the NumPy loop's numbers, NaN where NumPy has NaN."""
    rng = np.random.default_rng(11)
    n = 129
    s = _structure(tyre, ("longitudinal_load_transfer", "combined_slip"))
    p = VehicleParameters.from_settings(Settings.from_config(config), mu=rng.uniform(0.6, 1.0, n), l_f=rng.uniform(1.4, 1.7, n), v_c=V)
    speed, F_w = (np.full(3, V), np.array([0.0, -9.3, 9.3])), rng.uniform(-300.0, 300.0, (3, n))

    def make():
        return track_extended.ExtendedSingleTrackRHS(p, s, 0.97, np.deg2rad([2.0, 4.0, 6.0]), F_w, True, np.zeros(n), 2.5, T_W, speed_half=speed)

    x = np.vstack([rng.normal(0, 0.2, n), rng.normal(0, 0.6, n), rng.normal(0, 0.08, n), rng.normal(0, 1, n)])
    x[1, 5] = np.nan
    x[2, 17] = np.nan
    for half in (1, 2):
        out = {}
        for compiled in (False, True):
            monkeypatch.setattr(track_extended, "COMPILED_LOOP", compiled)
            rhs = make()
            out[compiled] = np.empty((rhs.n_states, n))
            rhs(x, half, out[compiled])
            assert rhs._compiled_loop == compiled
        np.testing.assert_array_equal(out[True], out[False])
        assert np.all(np.isnan(out[True][:, [5, 17]]).any(axis=0)) and np.isfinite(np.delete(out[True], [5, 17], axis=1)).all()
        shift = p.m * 9.3 * 2.5 / p.wheelbase  # what the pitch moves at 0.95 g, against the lighter axle's static load
        assert np.any(shift > (rhs.static[1] if half == 1 else rhs.static[0]))


@pytest.mark.parametrize("terms", [(False, True, False, True), (True, True, True, False)])
def test_llvm_vectorises_a_loads_step_that_needs_hundreds_of_alias_checks(terms):
    """The loads' step of the load-sensitive tyre (lateral transfer) and of the Magic Formula with
    pitch, lateral transfer and combined slip stores to 14 rows: LLVM vectorises it only within
    the raised limit of runtime alias checks (jit.MEMORY_CHECKS; at LLVM's own limits its IR has
    no vector of doubles). Compiled anew here: numba's disk cache keeps machine code, not IR."""
    fresh = njit(error_model="numpy")(loads_step(*terms).py_func)
    n = 16
    one, rows = np.ones(n), lambda r=2: np.zeros((r, n))
    fresh(one.copy(), np.ones((len(ROWS), n)), one, one, one, rows(), one, True, 0.0, 2.85, 10.6, 30.4, rows(), rows(), rows(), rows(), rows(),
          rows(4))
    assert re.search(r"<\d+ x double>", fresh.inspect_llvm(fresh.signatures[0]))


@pytest.mark.parametrize("terms", [(False, True, False, False, True, False), (True, True, True, False, False, True), (True, True, False, True, False, False)])
def test_llvm_vectorises_both_passes_of_the_loads_loop(terms):
    """The loads' loop inlines its Newton pass and its final pass (load_newton._one_pass, the
    terms constants): LLVM vectorises each of the two loops over the realisations (the lateral
    transfer on the Magic Formula; pitch, transfer, combined slip and the yielding front on the
    linear tyre; the load-sensitive tyre). Compiled anew here, as above."""
    fresh = njit(error_model="numpy")(newton_loop(*terms).py_func)
    n = 16
    one, rows = np.ones(n), lambda r=2: np.zeros((r, n))
    fresh(one.copy(), np.ones((len(ROWS), n)), one, one, one, one, rows(), rows(), one, rows(), rows(), rows(4), 2, 0.0, 2.85, 10.6, 30.4, 1.3)
    loops = set(re.findall(r"^(vector\.body[0-9.]*):", fresh.inspect_llvm(fresh.signatures[0]), re.M))
    assert len(loops) >= 2, loops

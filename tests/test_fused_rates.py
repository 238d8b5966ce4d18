"""The single-track right-hand side's compiled arithmetic (vehicle/dynamics/fused_rates.py) gives
the NumPy operations' numbers bit for bit, on every combination of the terms it serves, and the
right-hand sides it does not serve take the NumPy path."""

import itertools
from dataclasses import replace

import numpy as np
import pytest

import uqdrive.vehicle.dynamics.rhs as rhs_module
from uqdrive.config import load_config
from uqdrive.numerics.integrate import rk4_fixed_step_into
from uqdrive.settings import Settings
from uqdrive.vehicle.dynamics.jit import realisations
from uqdrive.vehicle.dynamics.rhs import HalfStepInputs, SingleTrackRHS
from uqdrive.vehicle.single_track import VehicleParameters

SETTINGS = Settings.from_config(load_config(None))
J = 41  # half steps of the tabulated inputs


def _rhs(fused: bool, n: int, quotient=False, heading=True, course=False, bank=False, speed=False, per_run_steer=False,
         per_run_terms=False, **more):
    """A Magic-Formula right-hand side of n realisations drawn from one seed; ``per_run_terms``
    makes E, the course weight and the bank per realisation (else numbers), ``per_run_steer`` the
    steering per realisation (else one table) and the wind's yaw moment a constant M_w."""
    rng = np.random.default_rng(7)
    p = VehicleParameters.from_settings(SETTINGS, mu=rng.normal(1.0, 0.2, n), l_f=rng.normal(1.55, 0.2, n), m_load=rng.normal(100, 30, n))
    delta = np.deg2rad(5.0) * np.sin(np.linspace(0.0, 3.0, J))
    if per_run_steer:
        delta = delta[:, None] * rng.normal(1.0, 0.1, n)
    inputs = HalfStepInputs(delta, rng.normal(0.0, 300.0, (J, n)), rng.normal(0.0, 300.0, n) if per_run_steer else None)
    kw = dict(heading=heading, quotient=quotient, **more)
    if course:
        kw["course_weight"] = rng.normal(0.3, 0.1, n) if per_run_terms else 0.4
    if bank:
        kw["lateral_acceleration"] = rng.normal(0.3, 0.1, n) if per_run_terms else 0.3
    if speed:
        kw["speed_half"] = (np.linspace(19.0, 15.0, J), np.full(J, -2.0))
    if per_run_terms:
        kw["E"] = rng.normal(0.9, 0.05, n)
    rhs_module.FUSED = fused
    try:
        return SingleTrackRHS(p, inputs, **kw)
    finally:
        rhs_module.FUSED = True


TERMS = ("quotient", "heading", "course", "bank", "speed", "per_run_steer", "per_run_terms")


@pytest.mark.parametrize("terms", list(itertools.product([False, True], repeat=len(TERMS))),
                         ids=lambda t: "-".join(k for k, on in zip(TERMS, t) if on) or "plain")
def test_the_compiled_rates_are_the_numpy_rates_bit_for_bit(terms):
    """Every combination of the balances' division, the heading and course rows, a bank, a speed
    profile with its v_dot term, per-realisation inputs and per-realisation E, k and a_lat: the
    same doubles at three half steps, on states with large side slip (|beta| to ~0.4 rad, where
    a rounding difference in the half-angle sine would show)."""
    settings = dict(zip(TERMS, terms))
    n = 53
    fused, numpy_path = _rhs(True, n, **settings), _rhs(False, n, **settings)
    assert fused.fused and not numpy_path.fused
    x = np.random.default_rng(3).normal(0.0, 0.15, (fused.n_states, n))
    a, b = np.empty_like(x), np.empty_like(x)
    for j in (0, 9, J - 1):
        fused(x, j, a)
        numpy_path(x, j, b)
        assert np.array_equal(a, b), (j, np.abs(a - b).max())


def test_an_ensemble_integrated_with_the_compiled_rates_is_the_numpy_ensemble_bit_for_bit():
    """RK4 over the inputs' 20 steps from states that grow through the slalom: every recorded
    state equal (a difference in the last bit of a rate would grow along the steps)."""
    out = {}
    for fused in (True, False):
        rhs = _rhs(fused, 300, speed=True, bank=True, course=True, per_run_terms=True)
        x0 = np.zeros((4, 300))
        out[fused] = rk4_fixed_step_into(rhs, x0, 0.01, (J - 1) // 2, 1)
    assert np.abs(out[True]).max() > 1e-3 and np.array_equal(out[True], out[False])


@pytest.mark.parametrize("case", ["linear tyre", "large C", "switched off"])
def test_rates_the_compiled_loop_does_not_serve_take_the_numpy_path(case):
    """The linear tyre, a shape factor whose angle C pi / 2 reaches 3 rad (np.sin, not the
    half-angle sine) and FUSED False are not fused; their rates are still finite."""
    n = 5
    if case == "linear tyre":
        rhs = _rhs(True, n, tyre="linear")
    elif case == "large C":
        base = _rhs(True, n)
        rhs = SingleTrackRHS(replace(VehicleParameters.from_settings(SETTINGS, mu=np.ones(n)), C=2.0), base.inputs)
    else:
        rhs = _rhs(False, n)
    assert not rhs.fused
    out = np.empty((4, n))
    rhs(np.full((4, n), 0.05), 3, out)
    assert np.all(np.isfinite(out))


def test_realisations_hands_the_loops_one_array_type():
    """jit.realisations: a writable C-contiguous float64 (n,) array is passed as it is; a number,
    a broadcast, another dtype and a read-only array come back as a writable (n,) float64 copy with
    the same values (a read-only array is its own type to numba: a loop compiled again)."""
    n = 7
    own = np.linspace(0.0, 1.0, n)
    assert realisations(own, n) is own
    frozen = own.copy()
    frozen.flags.writeable = False
    for given in (frozen, 0.5, np.float64(0.5), np.ones(1), np.arange(n), own[::-1], np.broadcast_to(own, (n,))):
        got = realisations(given, n)
        assert got.shape == (n,) and got.dtype == np.float64 and got.flags.c_contiguous and got.flags.writeable, given
        np.testing.assert_array_equal(got, np.broadcast_to(np.asarray(given, float), (n,)))
    assert realisations(frozen, n) is not frozen

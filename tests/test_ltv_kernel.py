"""The compiled RK4 pass of the linear single-track model along a speed profile
(uqdrive.vehicle.dynamics.ltv_rk4) gives the numbers of the NumPy reference,
rk4_fixed_step_into(LinearTrackRHS), bit for bit on every branch of the right-hand side; the data
are rich enough that an operation done in another order changes the bits."""

import itertools
from dataclasses import replace

import numpy as np
import pytest

from uqdrive.numerics.integrate import rk4_fixed_step_into
from uqdrive.settings import Settings
from uqdrive.vehicle.dynamics.ltv_rk4 import rk4_linear_track
from uqdrive.vehicle.effects import ModelStructure
from uqdrive.vehicle.single_track import VehicleParameters
from uqdrive.vehicle.track_rk4 import LinearTrackRHS, integrate_linear_ltv, speed_on_half_steps

N, H, STEPS = 40, 0.01, 1000  # a 10 s run at the simulators' RK4 step


@pytest.fixture(scope="module")
def car(config):
    """Per-realisation mu, load and l_f: every coefficient array differs between realisations."""
    rng = np.random.default_rng(5)
    return VehicleParameters.from_settings(Settings.from_config(config), mu=rng.uniform(0.5, 1.1, N), m_load=rng.uniform(0.0, 400.0, N),
                                           l_f=rng.uniform(1.1, 1.8, N))


def _braking_rhs(car, s, yaw_gust, heading, seed=0):
    """LinearTrackRHS braking 70 -> 45 km/h from 3 s to 6 s of a 10 s run, steered by a slalom, gusted at random."""
    rng = np.random.default_rng(seed)
    t = np.arange(1001) * 0.01
    t_half = np.arange(2 * STEPS + 1) * (H / 2)
    speed = (70.0 - 25.0 * np.clip((t - 3.0) / 3.0, 0.0, 1.0)) / 3.6
    v, v_dot = speed_on_half_steps(t, speed, t_half)
    delta_half = 0.03 * np.sin(2.1 * t_half) + 0.004 * rng.normal(size=t_half.size)
    F_w_half = 300.0 + rng.normal(size=(t_half.size, N)) * 400.0
    return LinearTrackRHS(car, s, delta_half, F_w_half, yaw_gust, rng.normal(size=N) * 300.0 + 200.0, v, v_dot, heading=heading)


def _kernel(rhs, record_every=5):
    return rk4_linear_track(H, STEPS, record_every, heading=rhs.heading, exact=rhs.exact, P=rhs.P, a12=rhs.a12, a13=rhs.a13, W1=rhs.W1,
                            Q=rhs.Q, R=rhs.R, S=rhs.S, inv_m=rhs.inv_m, M_term=rhs.M_term, a_lat=rhs.a_lat, k=rhs.k,
                            delta_half=rhs.delta_half, F_w_half=rhs.F_w_half, inv_v=rhs.inv_v, rate=rhs.rate)


def _reference(rhs, record_every=5):
    return rk4_fixed_step_into(rhs, np.zeros((rhs.n_states, N)), H, STEPS, record_every)


def _structure(k_array, exact, lateral, compliance=0.0):
    k = np.linspace(0.6, 1.4, N) if k_array else 0.9
    return replace(ModelStructure(), course_weight=k, course_exact=exact, lateral_acceleration=0.8 if lateral else 0.0,
                   compliance_steer=compliance)


@pytest.mark.parametrize("heading,exact,lateral,yaw_gust,k_array", list(itertools.product([True, False], repeat=5)))
def test_the_kernel_is_the_numpy_pass_bit_for_bit(car, heading, exact, lateral, yaw_gust, k_array):
    """Every branch: with and without psi and y, the exact course kinematics, a lateral
    acceleration, the gusts' yaw moment or the mean wind's, a scalar or per-realisation course weight."""
    rhs = _braking_rhs(car, _structure(k_array, exact, lateral, compliance=0.4), yaw_gust, heading)
    want = _reference(rhs)
    got = _kernel(rhs)
    assert got.shape == want.shape and np.all(np.isfinite(got))
    assert np.array_equal(got, want)


def test_integrate_linear_ltv_returns_the_reference_layout(car):
    """integrate_linear_ltv (the simulators' call) is the reference pass, (4, n, K + 1), psi and y
    NaN without heading; here with a lateral acceleration per realisation (pairs with and without
    it share a pass) and a read-only wind array."""
    for heading in (True, False):
        s = replace(_structure(True, True, False), lateral_acceleration=np.repeat([0.0, 0.8], N // 2))
        rhs = _braking_rhs(car, s, False, heading, seed=3)
        rhs.F_w_half.flags.writeable = False
        want = _reference(rhs, 10)
        if not heading:
            full = np.full((want.shape[0], 4, N), np.nan)
            full[:, 1:3] = want
            want = full
        assert np.array_equal(integrate_linear_ltv(rhs, H, STEPS, 10), want.transpose(1, 2, 0), equal_nan=True)


class _Reordered(LinearTrackRHS):
    """The reference right-hand side with one operation in another order (each exact in real arithmetic)."""

    def __init__(self, *args, variant, **kwargs):
        super().__init__(*args, **kwargs)
        self.variant = variant

    def __call__(self, x, j, out):
        super().__call__(x, j, out)
        i_r, i_b = self._rows
        r, b, iv, u = x[i_r], x[i_b], self.inv_v[j], self._inputs(j)
        if self.variant == "control":
            o2 = (self.Q * r) * (iv * iv) - r + (self.R * b) * iv - b * self.rate[j] + u[2] + u[3]
        elif self.variant == "o2 *= iv; o2 *= iv":
            o2 = self.Q * r * iv * iv - r + (self.R * b) * iv - b * self.rate[j] + u[2] + u[3]
        elif self.variant == "u[3] before u[2]":
            o2 = (self.Q * r) * (iv * iv) - r + (self.R * b) * iv - b * self.rate[j] + u[3] + u[2]
        else:  # "P r / v as P (r / v)"
            o1 = self.P * (r * iv) + self.a12 * b + u[0] + u[1]
            out[i_r] = o1
            return
        out[i_b] = o2


@pytest.mark.parametrize("variant", ["o2 *= iv; o2 *= iv", "u[3] before u[2]", "P r / v as P (r / v)"])
def test_an_operation_in_another_order_changes_the_bits(car, variant):
    """The comparison above can fail: the data are not so simple that every order rounds alike.
    The unchanged reference written out term by term is the control (equal bits), each reordering differs."""
    base = _braking_rhs(car, _structure(False, False, False), True, False)
    args = (car, _structure(False, False, False), base.delta_half, base.F_w_half, True, np.zeros(N), base.v_half, base.v_dot_half)
    want = _kernel(base)
    assert np.array_equal(_reference(base), want)
    assert np.array_equal(_reference(_Reordered(*args, heading=False, variant="control")), want)
    moved = _reference(_Reordered(*args, heading=False, variant=variant))
    assert not np.array_equal(moved, want)
    assert np.allclose(moved, want, rtol=1e-9, atol=1e-12)  # a rounding, not another model


def test_the_lateral_acceleration_of_every_time_at_once_is_each_times_bit_for_bit(car):
    """rk4_lateral_acceleration reads a_y of all recorded times in one element-wise pass
    (LinearTrackRHS.lateral_acceleration_along): the numbers of a call per time, with a compliance
    steer (the coefficients of the softened front axle) and per-realisation parameters; a per-time
    speed taken from the wrong half step would change them."""
    from uqdrive.vehicle.track_rk4 import rk4_lateral_acceleration

    rhs = _braking_rhs(car, _structure(False, False, True, compliance=0.4), True, False)
    x = integrate_linear_ltv(rhs, H, STEPS, 5)
    js = np.arange(x.shape[2]) * 10
    each = np.stack([rhs.lateral_acceleration(np.ascontiguousarray(x[:, :, k]), j) for k, j in enumerate(js)], axis=-1)
    together = rk4_lateral_acceleration(rhs, x, js)
    assert together.shape == each.shape == (N, js.size) and np.all(np.isfinite(together))
    assert np.array_equal(together, each)
    assert not np.array_equal(rhs.lateral_acceleration_along(x, np.maximum(js - 1, 0)), each)

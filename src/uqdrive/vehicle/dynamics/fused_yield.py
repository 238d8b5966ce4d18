"""The Magic-Formula front wheels' yield to their own force (compliance steer) compiled between
NumPy's arctangents and tangents: :func:`uqdrive.vehicle.axle_loads.yielded_front_slip` bit for bit.

Each of its three Newton steps is some twenty NumPy calls on (n,) arrays, most of their cost per
call at a discover fit's few hundred realisations; here two arctangents and a tangent by NumPy
(its SIMD functions, the same numbers) and the arithmetic between them as loops, each element by
the NumPy path's operations in its order (no multiply-add contraction without fastmath). On
loads that follow the tyres' force the yield runs at each step of the loads' Newton loop
(:func:`yielding_newton`).
"""

from __future__ import annotations

import numpy as np

from .fused_rates import half_angle_pair, half_angle_sine, item
from .jit import compiled, factor
from .load_newton import KAPPA, MU, STATIC_F, STATIC_R, stepwise_newton

__all__ = ["FrontYield", "yielding_newton"]

NEWTON_STEPS = 3  # axle_loads.yielded_front_slip's


@compiled
def _first(q0, peak, B, C, kappa, q, bx):
    """The linear tyre's yield q = q0 / max(1 + kappa peak B C, 0.05), and B q into ``bx``."""
    for i in range(q0.shape[0]):
        b = item(B, i)
        stiff = peak[i] * b
        stiff = stiff * item(C, i)
        den = kappa[i] * stiff
        den = 1.0 + den
        den = 0.05 if den < 0.05 else den
        q[i] = q0[i] / den
        bx[i] = b * q[i]


@compiled
def _argument(bx, atan_bx, E, u):
    """The curved argument u = B x - E (B x - atan(B x)) (single_track.curvature_argument)."""
    for i in range(bx.shape[0]):
        d = bx[i] - atan_bx[i]
        d = E[i] * d
        u[i] = bx[i] - d


@compiled
def _half_angle(atan_u, C, h):
    """Half the tyre's angle, 0.5 (C atan(u))."""
    for i in range(atan_u.shape[0]):
        a = item(C, i) * atan_u[i]
        h[i] = 0.5 * a


@compiled
def _newton_step(t, u, bx, q0, peak, B, C, E, kappa, q):
    """One Newton step q <- q - (q - q0 + kappa peak sin a) / max(1 + kappa dF/dq, 0.05) from
    t = tan(a / 2), and B q into ``bx``."""
    for i in range(t.shape[0]):
        b, c = item(B, i), item(C, i)
        sin_a, cos_a = half_angle_pair(t[i])
        slope = peak[i] * cos_a
        slope = slope * c
        slope = slope / (1.0 + u[i] * u[i])
        slope = slope * b
        g = 1.0 - E[i]
        g = g + E[i] / (1.0 + bx[i] * bx[i])
        slope = slope * g
        num = q[i] - q0[i]
        num = num + kappa[i] * (peak[i] * sin_a)
        den = 1.0 + kappa[i] * slope
        den = 0.05 if den < 0.05 else den
        q[i] = q[i] - num / den
        bx[i] = b * q[i]


@compiled
def _unit_and_wheel(t, q0, q, wheel, unit, h):
    """sin of the yielded slip's tyre angle (from t = tan(a / 2)) into ``unit`` and half the wheel
    angle it leaves, 0.5 (wheel - (q0 - q)), into ``h``."""
    for i in range(t.shape[0]):
        unit[i] = half_angle_sine(t[i])
        w = q0[i] - q[i]
        w = wheel[i] - w
        h[i] = 0.5 * w


@compiled
def _cosine(t, out):
    """cos of the angle whose half-angle tangent is ``t``, (1 - t^2) / (1 + t^2) (axle_loads.half_angle_sin_cos)."""
    for i in range(t.shape[0]):
        out[i] = half_angle_pair(t[i])[1]


class FrontYield:
    """The yield of the front wheels on the Magic Formula for ``n`` realisations: its work arrays.

    Parameters
    ----------
    n : int
        Realisations.
    B, C : float or ndarray, shape (n,)
        The front's stiffness factor and the shape factor (-), one for all realisations or each its own.
    E, kappa : ndarray, shape (n,)
        The curvature factor (-) and the front wheel angle per newton of the front axle's force (rad/N).
    """

    def __init__(self, n: int, B, C, E, kappa):
        self.B, self.C, self.E, self.kappa = factor(B, n), factor(C, n), E, kappa
        self.q, self.bx, self.at, self.u, self.h, self.t = (np.empty(n) for _ in range(6))

    def _tangent(self) -> None:
        """t = tan(0.5 C atan(u(B q))) of the current ``bx``."""
        np.arctan(self.bx, self.at)
        _argument(self.bx, self.at, self.E, self.u)
        np.arctan(self.u, self.at)
        _half_angle(self.at, self.C, self.h)
        np.tan(self.h, self.t)

    def __call__(self, q0, peak, wheel, unit, cos_wheel) -> None:
        """The front's force per unit peak at its yielded slip into ``unit`` (n,) and cos of the
        wheel angle the yield leaves into ``cos_wheel`` (n,), from the steady front slip ``q0``
        (rad), the front's peak force ``peak`` (N) and the wheel angle ``wheel`` (rad), each (n,)
        C-contiguous: yielded_front_slip, then half_angle_sin_cos(tyre_angle(B q)) and
        half_angle_sin_cos(wheel - (q0 - q)) of ExtendedSingleTrackRHS._at_loads, the same numbers."""
        q, bx = self.q, self.bx
        _first(q0, peak, self.B, self.C, self.kappa, q, bx)
        for _ in range(NEWTON_STEPS):
            self._tangent()
            _newton_step(self.t, self.u, bx, q0, peak, self.B, self.C, self.E, self.kappa, q)
        self._tangent()
        _unit_and_wheel(self.t, q0, q, wheel, unit, self.h)
        np.tan(self.h, self.t)
        _cosine(self.t, cos_wheel)


@compiled
def _yield_step(T, K, front, P, dP, peak, unit, B_f, C, has_slope):
    """One Newton step of :func:`yielding_newton` from the forces peak unit (``front``: cos of the
    yielded wheel angle), the front's slope divided by 1 + kappa mu P B C (the loads' loop's order)."""
    for i in range(T.shape[0]):
        F_f = peak[0, i] * unit[0, i]
        F_r = peak[1, i] * unit[1, i]
        floor_f, floor_r = 1e-3 * K[STATIC_F, i], 1e-3 * K[STATIC_R, i]
        dF_f = F_f / (floor_f if P[0, i] < floor_f else P[0, i])
        dF_r = F_r / (floor_r if P[1, i] < floor_r else P[1, i])
        dF_f /= 1.0 + K[KAPPA, i] * P[0, i] * K[MU, i] * item(B_f, i) * item(C, i)
        fr, x = front[i], T[i]
        if has_slope:
            den = 1.0 - (fr * dF_f * dP[0, i] + dF_r * dP[1, i])
            T[i] = x + (fr * F_f + F_r - x) / (0.05 if den < 0.05 else den)
        else:  # NumPy's scalar slope 0: max(1 - 0, 0.05)
            T[i] = x + (fr * F_f + F_r - x) / 1.0


def yielding_newton(T, K, trig, q0, wheel, unit, F_w, steps: int, v_dot: float, L: float, B_f, C, front_yield, out,
                    *, pitching: bool, transferring: bool, slipping: bool) -> None:
    """Newton's method on the tyres' lateral force T (N) of a Magic-Formula chassis model whose
    front wheels yield to their force (compliance steer) on loads that follow T.

    Per realisation the operations of the NumPy loop in
    :meth:`uqdrive.vehicle.track_extended.ExtendedSingleTrackRHS._forces` (Rajamani eq. (2.27),
    Gillespie eq. (2-4)): at each of ``steps`` steps the loads and peaks of T, the front's yield
    q = q0 - kappa F_f(q) on that peak (``front_yield``,
    :func:`uqdrive.vehicle.axle_loads.yielded_front_slip`) and :func:`.load_newton.newton_loads`'
    update, the front's slope divided by 1 + kappa mu P_f B C; then the loads and the yield at the last T.

    Parameters
    ----------
    T : ndarray, shape (n,)
        The steady guess (N), overwritten by the loop's result.
    K : ndarray, shape (len(ROWS), n)
        Per-realisation constants, rows :data:`.load_newton.ROWS` (kg, m/s^2, m, N, N, m/m, m/m, -, -, rad/N, -, -, -, -, -, -, -, m, N, N).
    trig : ndarray, shape (3, n)
        tan, cos and sin of the side slip beta (-).
    q0 : ndarray, shape (n,)
        The front's steady slip angle (rad), the wheel angle's alone.
    wheel : ndarray, shape (n,)
        The front wheel angle (rad), the roll steer's taken off.
    unit : ndarray, shape (2, n)
        The force per unit peak (-): the rear's row is read (the load-free curve at its slip),
        the front's row is written (the yielded slip's at the returned T).
    F_w : ndarray, shape (n,)
        Side wind (N) at the half step.
    steps : int
        Newton steps (:data:`uqdrive.vehicle.track_extended.LOAD_NEWTON_STEPS`).
    v_dot, L : float
        Speed rate (m/s^2) and wheelbase (m).
    B_f, C : float or ndarray, shape (n,)
        The front's stiffness factor (-) and the shape factor (-) (:func:`.jit.factor`).
    front_yield : callable
        ``front_yield(q0, peak, wheel, unit, cos_wheel)`` (:class:`FrontYield`).
    out : tuple of ndarray
        Work arrays ``(P, dP, peak, capacity, factors, bx, cos_wheel)``, shapes (2, n), factors
        (4, n), cos_wheel (n,): at return ``P`` (N), ``capacity`` (-) and ``cos_wheel`` (-), the
        loads, the lateral shares and cos of the yielded wheel angle at the result.
    pitching, transferring, slipping : bool
        Longitudinal transfer, lateral transfer, combined slip.
    """
    P, dP, peak, capacity, factors, bx, cos_wheel = out
    # the slip angles and B_r (here unit and B_f) are read by the load-sensitive tyre's step alone
    stepwise_newton(T, K, trig, unit, F_w, steps, v_dot, L, B_f, B_f, (P, dP, peak, bx, capacity, factors),
                    lambda: front_yield(q0, peak[0], wheel, unit[0], cos_wheel),
                    lambda has_slope: _yield_step(T, K, cos_wheel, P, dP, peak, unit, B_f, C, has_slope),
                    pitching=pitching, transferring=transferring, slipping=slipping, sensitive=False)

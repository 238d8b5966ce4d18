"""The Magic-Formula front wheels' yield to their own force (compliance steer) compiled between
NumPy's arctangents and tangents: :func:`uqdrive.vehicle.axle_loads.yielded_front_slip` bit for bit.

Each of its three Newton steps is some twenty NumPy calls on (n,) arrays, most of their cost per
call at a discover fit's few hundred realisations; here two arctangents and a tangent by NumPy
(its SIMD functions, the same numbers) and the arithmetic between them as loops, each element by
the NumPy path's operations in its order (no multiply-add contraction without fastmath).
"""

from __future__ import annotations

import numpy as np

from .fused_rates import half_angle_pair, half_angle_sine
from .jit import compiled

__all__ = ["FrontYield"]

NEWTON_STEPS = 3  # axle_loads.yielded_front_slip's


@compiled
def _first(q0, peak, B, C, kappa, q, bx):
    """The linear tyre's yield q = q0 / max(1 + kappa peak B C, 0.05), and B q into ``bx``."""
    for i in range(q0.shape[0]):
        stiff = peak[i] * B
        stiff = stiff * C
        den = kappa[i] * stiff
        den = 1.0 + den
        den = 0.05 if den < 0.05 else den
        q[i] = q0[i] / den
        bx[i] = B * q[i]


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
        a = C * atan_u[i]
        h[i] = 0.5 * a


@compiled
def _newton_step(t, u, bx, q0, peak, B, C, E, kappa, q):
    """One Newton step q <- q - (q - q0 + kappa peak sin a) / max(1 + kappa dF/dq, 0.05) from
    t = tan(a / 2), and B q into ``bx``."""
    for i in range(t.shape[0]):
        sin_a, cos_a = half_angle_pair(t[i])
        slope = peak[i] * cos_a
        slope = slope * C
        slope = slope / (1.0 + u[i] * u[i])
        slope = slope * B
        g = 1.0 - E[i]
        g = g + E[i] / (1.0 + bx[i] * bx[i])
        slope = slope * g
        num = q[i] - q0[i]
        num = num + kappa[i] * (peak[i] * sin_a)
        den = 1.0 + kappa[i] * slope
        den = 0.05 if den < 0.05 else den
        q[i] = q[i] - num / den
        bx[i] = B * q[i]


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
    B, C : float
        The front's stiffness factor and the shape factor (-).
    E, kappa : ndarray, shape (n,)
        The curvature factor (-) and the front wheel angle per newton of the front axle's force (rad/N).
    """

    def __init__(self, n: int, B: float, C: float, E, kappa):
        self.B, self.C, self.E, self.kappa = float(B), float(C), E, kappa
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

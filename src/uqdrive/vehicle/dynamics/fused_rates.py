"""The single-track right-hand side's arithmetic between its transcendental calls, compiled: the
Magic-Formula rates of :class:`.rhs.SingleTrackRHS` in thirteen calls instead of ~50, bit for bit.

At the few hundred to few thousand realisations of a discover fit, NumPy spends most of a
right-hand side's time per call, not per element: ~45 arithmetic operations on (n,) and (2, n)
arrays around six transcendental ones. The transcendentals stay NumPy's (its SIMD tangent and
arctangent; numba's are scalar libm calls, slower and rounded otherwise); the arithmetic between
them runs here, per realisation, in NumPy's order (numba contracts no multiply-add without
fastmath), so every number is the NumPy path's. Arguments that may be a number or an array (n,)
are read by ``item``; each combination of their types is compiled once (~1 s) and cached on disk.
"""

from __future__ import annotations

import numpy as np
from numba import njit, types
from numba.extending import overload

from .jit import compiled, realisations

__all__ = ["FusedRates", "curvature_from_atan", "half_angle_pair", "half_angle_sine", "half_tyre_angle", "item", "side_slip_at"]


def item(a, i):  # pragma: no cover - replaced by the overload inside compiled code
    """Realisation ``i``'s value of ``a``, a number (the same for all) or an array (n,), in compiled code."""
    return a if np.ndim(a) == 0 else a[i]


@overload(item, inline="always")
def _item_compiled(a, i):
    if isinstance(a, types.Array):
        return lambda a, i: a[i]
    return lambda a, i: a


@njit(error_model="numpy")
def half_angle_sine(t):
    """sin of the angle whose half-angle tangent is ``t`` (axle_loads.half_angle_sin_cos_into's order)."""
    inv = t * t
    inv = inv + 1.0
    inv = 1.0 / inv
    s = t * 2.0
    return s * inv


@njit(error_model="numpy")
def half_angle_pair(t):
    """sin and cos of the angle whose half-angle tangent is ``t`` (axle_loads.half_angle_sin_cos_into's order)."""
    inv = t * t
    c = 1.0 - inv
    inv = inv + 1.0
    inv = 1.0 / inv
    c = c * inv
    s = t * 2.0
    s = s * inv
    return s, c


@njit(error_model="numpy")
def side_slip_at(t, i, sin_b, cos_b, lever, psi_dot, v, q):
    """Realisation ``i`` of :func:`_slip_argument`; returns its sin and cos of beta."""
    s, c = half_angle_pair(t[i])
    sin_b[i] = s
    cos_b[i] = c
    w = s * v
    den = c * v
    q[0, i] = (lever[0, i] * psi_dot[i] + w) / den
    q[1, i] = (lever[1, i] * psi_dot[i] + w) / den
    return s, c


@compiled
def _slip_argument(t, sin_b, cos_b, lever, psi_dot, v, q):
    """From t = tan(beta / 2): sin and cos of beta (half_angle_sin_cos_into) into ``sin_b``,
    ``cos_b`` and the slip angles' arctan argument (lever psi_dot + v sin beta) / (v cos beta) (rhs.slip_angles) into ``q`` (2, n)."""
    for i in range(t.shape[0]):
        side_slip_at(t, i, sin_b, cos_b, lever, psi_dot, v, q)


@compiled
def _stiffness_argument(q, delta, B_f, B_r, bx):
    """B alpha (2, n) into ``bx`` from q = atan(argument): alpha = -q, the front's plus delta."""
    for i in range(q.shape[1]):
        a_f = -q[0, i]
        a_f = a_f + item(delta, i)
        bx[0, i] = item(B_f, i) * a_f
        bx[1, i] = item(B_r, i) * -q[1, i]


@compiled
def curvature_from_atan(bx, E, F):
    """u = B x - E (B x - atan(B x)) into ``F``, which holds atan(B x) (single_track.curvature_argument)."""
    for i in range(bx.shape[1]):
        e = item(E, i)
        for r in range(2):
            u = bx[r, i] - F[r, i]
            u = u * e
            F[r, i] = bx[r, i] - u


@compiled
def half_tyre_angle(F, C, t):
    """Half the tyre's angle C atan(u) into ``t`` (2, n), ``F`` holding atan(u); ``C`` a number or (n,)."""
    for i in range(F.shape[1]):
        c = item(C, i)
        for r in range(2):
            a = F[r, i] * c
            t[r, i] = a * 0.5


@compiled
def _balances(t, peak, cos_delta, l_f, l_r, F_w, M_c, M_w, has_M_w, yaw_factor, mass_factor, quotient, cos_b, sin_b, psi_dot,
              a_v, has_a_v, v_dot_v, has_v_dot, yaw_out, slip_out, beta, psi, k, course, heading, psi_out, y_out):
    """The axle forces D sin(angle) from t = tan(angle / 2) and the yaw and lateral balances
    (rhs.Balance.rates: ``quotient`` divides by the factors, else multiplies; a bank's a_v, the
    speed change's -(v_dot / v) sin beta, each where its ``has_`` flag is set); with ``heading``,
    psi_dot into ``psi_out`` and psi + k beta (``course``, else psi) into ``y_out``. The flags
    hold for the whole loop (runtime arguments: one compiled loop serves every combination)."""
    for i in range(t.shape[1]):
        F_f = half_angle_sine(t[0, i]) * peak[0, i]
        F_r = half_angle_sine(t[1, i]) * peak[1, i]
        front = F_f * item(cos_delta, i)
        F_wi = item(F_w, i)
        yaw = item(l_f, i) * front
        yaw = yaw - item(l_r, i) * F_r
        yaw = yaw + (item(M_w, i) if has_M_w else F_wi * M_c)
        yaw = yaw / item(yaw_factor, i) if quotient else yaw * item(yaw_factor, i)
        slip = front + F_r
        slip = slip + F_wi
        slip = slip * cos_b[i]
        slip = slip / item(mass_factor, i) if quotient else slip * item(mass_factor, i)
        slip = slip - psi_dot[i]
        if has_a_v:
            slip = slip + item(a_v, i)
        if has_v_dot:
            slip = slip - v_dot_v * sin_b[i]
        yaw_out[i] = yaw
        slip_out[i] = slip
        if heading:
            psi_out[i] = psi_dot[i]
            y_out[i] = beta[i] * item(k, i) + psi[i] if course else psi[i]


def _number(a):
    """A 0-d array as its float (compiled code indexes arrays); anything else as it is."""
    return float(a) if isinstance(a, np.ndarray) and a.ndim == 0 else a


class FusedRates:
    """:meth:`.rhs.SingleTrackRHS._rates` of a Magic-Formula right-hand side whose tyre angle
    takes the half-angle sine, the same numbers: its constants (each kept as an array (n,) whether
    or not it varies, as :class:`.fused_chassis.ChassisConstants` keeps them: one compiled loop
    for every model, not one per combination of numbers and arrays) and its work arrays.

    Parameters
    ----------
    lever : ndarray, shape (2, n)
        [l_f, -l_r] (m).
    peak : ndarray, shape (2, n)
        The axles' peak forces D (N).
    B : tuple of two floats
        The front and rear stiffness factors (-).
    C : float
        Shape factor (-).
    E : float or ndarray, shape (n,)
        Curvature factor (-).
    l_f, l_r, M_c, yaw_factor : float or ndarray, shape (n,)
        The balances' lever arms (m), the wind's yaw lever (m) and I_z or 1 / I_z (``quotient``).
    quotient : bool
        The balances divide by I_z and their mass factor (else multiply).
    course_weight : float or ndarray, shape (n,), or None
        k of psi + k beta (-); None: the heading psi.
    heading : bool
        The states hold psi and y (rows 0 and 3) besides psi_dot and beta.
    """

    def __init__(self, lever, peak, B, C, E, l_f, l_r, M_c, yaw_factor, quotient: bool, course_weight, heading: bool):
        n = lever.shape[1]
        self.lever, self.peak = np.ascontiguousarray(lever, float), np.ascontiguousarray(peak, float)
        self.B_f, self.B_r, self.C = float(B[0]), float(B[1]), float(C)
        self.E, self.l_f, self.l_r = realisations(E, n), realisations(l_f, n), realisations(l_r, n)
        self.M_c, self.yaw_factor, self.quotient = float(M_c), realisations(yaw_factor, n), bool(quotient)
        self.course = course_weight is not None
        self.k = realisations(0.0 if course_weight is None else course_weight, n)
        self.heading = bool(heading)
        self.rows = (1, 2) if heading else (0, 1)
        self.sin_b, self.cos_b, self.t = np.empty(n), np.empty(n), np.empty(n)
        self.q, self.bx, self.F = np.empty((2, n)), np.empty((2, n)), np.empty((2, n))

    def __call__(self, x, out, delta, cos_delta, F_w, M_w, v, mass_factor, a_v, v_dot) -> None:
        """dx/dt of ``x`` into ``out`` (n_states, n), float64, from the inputs of one half step as
        :meth:`.rhs.SingleTrackRHS._rates` receives them (numbers or arrays (n,); M_w, a_v and v_dot may be None)."""
        psi_dot, beta = x[self.rows[0]], x[self.rows[1]]
        t, q, bx, F = self.t, self.q, self.bx, self.F
        np.multiply(beta, 0.5, t)
        np.tan(t, t)
        _slip_argument(t, self.sin_b, self.cos_b, self.lever, psi_dot, float(v), q)
        np.arctan(q, q)
        _stiffness_argument(q, _number(delta), self.B_f, self.B_r, bx)
        np.arctan(bx, F)
        curvature_from_atan(bx, self.E, F)
        np.arctan(F, F)
        half_tyre_angle(F, self.C, bx)
        np.tan(bx, bx)
        heading = self.heading
        rows = x if heading else out  # psi and the course's rows: unused without the heading
        _balances(bx, self.peak, _number(cos_delta), self.l_f, self.l_r, _number(F_w), self.M_c,
                  0.0 if M_w is None else _number(M_w), M_w is not None, self.yaw_factor, _number(mass_factor), self.quotient,
                  self.cos_b, self.sin_b, psi_dot, 0.0 if a_v is None else _number(a_v), a_v is not None,
                  0.0 if v_dot is None else v_dot / v, v_dot is not None, out[self.rows[0]], out[self.rows[1]], beta, rows[0],
                  self.k, self.course, heading, out[0], out[-1])
        if heading:
            y_rate = out[3]
            np.sin(y_rate, y_rate)
            y_rate *= v

"""The compiled RK4 pass of the linear single-track model along a speed profile: every step and
realisation in one numba loop, the numbers of the NumPy right-hand side bit for bit.

numba is imported with this module, which only the integration along a speed profile imports.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .jit import compiled

__all__ = ["rk4_linear_track"]


@njit(error_model="numpy")
def _stage(psi, r, b, iv, d, F, rate, heading, exact, has_lat, yaw_gust, P, a12, a13, W1, Q, R, S, inv_m, M_term, a_lat, k):
    """dx/dt (psi_dot, psi_ddot, beta_dot, y_dot) of one realisation at one half step (its
    speed's 1 / v ``iv`` and v_dot / v ``rate``, steering ``d``, wind ``F``): the operations of
    LinearTrackRHS.__call__ and its _inputs, in their order."""
    # the state-free terms (LinearTrackRHS._inputs)
    u0 = a13 * d
    u2 = S * (d * iv)
    u3 = inv_m * F
    u3 *= iv
    # psi_ddot
    o1 = P * r
    o1 *= iv
    o1 += a12 * b
    o1 += u0
    o1 += W1 * F if yaw_gust else M_term
    # beta_dot
    o2 = Q * r
    o2 *= iv * iv
    o2 -= r
    t = R * b
    t *= iv
    o2 += t
    o2 -= b * rate
    o2 += u2
    o2 += u3
    if has_lat:
        o2 += a_lat * iv
    o0 = o3 = 0.0
    if heading:
        o0 = r
        o3 = b * k
        o3 += psi
        if exact:
            o3 = math.sin(o3)
        o3 /= iv
    return o0, o1, o2, o3


@njit(inline="always", error_model="numpy")
def _steps(out, h, n_steps, record_every, heading, exact, has_lat, yaw_gust, C, delta_half, F_w_half, inv_v, rate):
    """``out`` (K + 1, d, n): the states from rest every ``record_every`` steps; ``C`` (11, n):
    the coefficients P, a12, a13, W1, Q, R, S, inv_m, M_term, a_lat, k as rows (one array: the
    loop over realisations then reads few enough arrays to be vectorised).

    Per realisation and stage the operations of
    :meth:`uqdrive.vehicle.track_rk4.LinearTrackRHS.__call__` and its ``_inputs``, in their order
    (no fused multiply-add: numba contracts none without fastmath), and the stage sums of
    :func:`uqdrive.numerics.integrate.rk4_fixed_step_into`: the next stage's state h/2 k + x
    (h k3 + x), the step x + (h/6)(k1 + 2 (k2 + k3) + k4) summed as it sums them.
    """
    n = C.shape[1]
    half, sixth = 0.5 * h, h / 6.0
    x = np.zeros((4, n))  # psi, psi_dot, beta, y (psi and y stay 0 without heading)
    for i in range(n_steps):
        j = 2 * i
        iv0, iv1, iv2 = inv_v[j], inv_v[j + 1], inv_v[j + 2]
        d0, d1, d2 = delta_half[j], delta_half[j + 1], delta_half[j + 2]
        q0, q1, q2 = rate[j], rate[j + 1], rate[j + 2]
        for m in range(n):
            F0, F1, F2 = F_w_half[j, m], F_w_half[j + 1, m], F_w_half[j + 2, m]
            c = (C[0, m], C[1, m], C[2, m], C[3, m], C[4, m], C[5, m], C[6, m], C[7, m], C[8, m], C[9, m], C[10, m])
            p0, r0, b0 = x[0, m], x[1, m], x[2, m]
            k1 = _stage(p0, r0, b0, iv0, d0, F0, q0, heading, exact, has_lat, yaw_gust, *c)
            k2 = _stage(k1[0] * half + p0, k1[1] * half + r0, k1[2] * half + b0, iv1, d1, F1, q1, heading, exact, has_lat, yaw_gust, *c)
            k3 = _stage(k2[0] * half + p0, k2[1] * half + r0, k2[2] * half + b0, iv1, d1, F1, q1, heading, exact, has_lat, yaw_gust, *c)
            k4 = _stage(k3[0] * h + p0, k3[1] * h + r0, k3[2] * h + b0, iv2, d2, F2, q2, heading, exact, has_lat, yaw_gust, *c)
            x[1, m] = r0 + (((k2[1] + k3[1]) * 2.0 + k1[1]) + k4[1]) * sixth
            x[2, m] = b0 + (((k2[2] + k3[2]) * 2.0 + k1[2]) + k4[2]) * sixth
            if heading:
                x[0, m] = p0 + (((k2[0] + k3[0]) * 2.0 + k1[0]) + k4[0]) * sixth
                x[3, m] = x[3, m] + (((k2[3] + k3[3]) * 2.0 + k1[3]) + k4[3]) * sixth
        if (i + 1) % record_every == 0:
            if heading:
                out[(i + 1) // record_every] = x
            elif out.shape[1] == 4:  # padded: psi and y rows left as given (NaN)
                out[(i + 1) // record_every, 1:3] = x[1:3]
            else:
                out[(i + 1) // record_every] = x[1:3]
    return out


def _rates_pass(out, h, n_steps, record_every, has_lat, yaw_gust, C, delta_half, F_w_half, inv_v, rate):
    """:func:`_steps` of psi_dot and beta alone."""
    return _steps(out, h, n_steps, record_every, False, False, has_lat, yaw_gust, C, delta_half, F_w_half, inv_v, rate)


def _heading_pass(out, h, n_steps, record_every, has_lat, yaw_gust, C, delta_half, F_w_half, inv_v, rate):
    """:func:`_steps` of psi, psi_dot, beta and y, y_dot = v (psi + k beta)."""
    return _steps(out, h, n_steps, record_every, True, False, has_lat, yaw_gust, C, delta_half, F_w_half, inv_v, rate)


def _exact_course_pass(out, h, n_steps, record_every, has_lat, yaw_gust, C, delta_half, F_w_half, inv_v, rate):
    """:func:`_steps` of psi, psi_dot, beta and y, y_dot = v sin(psi + k beta)."""
    return _steps(out, h, n_steps, record_every, True, True, has_lat, yaw_gust, C, delta_half, F_w_half, inv_v, rate)


# heading and the course kinematics compiled into separate loops: branches on them inside the
# loop over realisations keep LLVM from vectorising it (8-40x slower); the other two do not
# (each compiled at its first call)
_rates_pass, _heading_pass, _exact_course_pass = (compiled(f) for f in (_rates_pass, _heading_pass, _exact_course_pass))


def rk4_linear_track(h: float, n_steps: int, record_every: int, *, heading: bool, exact: bool, P, a12, a13, W1, Q, R, S, inv_m, M_term,
                     a_lat, k, delta_half, F_w_half, inv_v, rate, padded: bool = False):
    """States of the linear single-track model (5.4) along a speed profile from rest, by RK4.

    The right-hand side, with the speed v_j and its rate v_dot_j on the half-step grid and the
    coefficients with the speed factored out
    (:func:`~uqdrive.vehicle.single_track.lst_speed_coefficients`)::

        psi_ddot = (P / v) r + a12 beta + a13 delta + W1 F_w            (or + M_term for mean-wind yaw)
        beta_dot = (Q / v^2 - 1) r + (R / v - v_dot / v) beta + S delta / v + inv_m F_w / v + a_lat / v
        psi_dot  = r,   y_dot = v (psi + k beta)                       (or v sin(psi + k beta), ``exact``)

    integrated by classical RK4 (x + (h/6)(k1 + 2 (k2 + k3) + k4)) with the numbers of
    ``rk4_fixed_step_into(LinearTrackRHS(...))`` bit for bit: each operation in the order
    :class:`~uqdrive.vehicle.track_rk4.LinearTrackRHS` performs it.

    Parameters
    ----------
    h : float
        RK4 step (s).
    n_steps, record_every : int
        Steps, and the stride of the returned states (``n_steps`` a multiple of it).
    heading : bool
        States psi, psi_dot, beta, y (4); False: psi_dot and beta alone (2).
    exact : bool
        The exact course kinematics v sin(psi + k beta).
    P, a12, a13, W1, Q, R, S, inv_m : ndarray, shape (n,)
        Per-realisation coefficients (LinearTrackRHS's attributes of those names; units such that
        each term is rad/s^2 or rad/s).
    M_term : ndarray, shape (n,), or None
        Mean-wind yaw moment over I_z, in the units of psi_ddot (rad/s^2); None: the gusts' W1 F_w instead.
    a_lat : float or ndarray, shape (n,)
        Lateral acceleration (m/s^2) of the road (zero: the term is left out, as the NumPy path does).
    k : float or ndarray, shape (n,)
        Course weight of beta in the course angle (-).
    delta_half : ndarray, shape (J,)
        Actual steering angle (rad) on the half-step grid, J = 2 ``n_steps`` + 1.
    F_w_half : ndarray, shape (J, n)
        Side wind (N) per half step and realisation.
    inv_v, rate : ndarray, shape (J,)
        1 / v (s/m) and v_dot / v (1/s) per half step, as LinearTrackRHS precomputes them.
    padded : bool
        Without ``heading``, return all four states with psi and y NaN (the simulators' layout,
        written in place: no second array).

    Returns
    -------
    ndarray, shape (n_steps // record_every + 1, d, n)
        The states every ``record_every`` steps from t = 0, d = 4 (psi, psi_dot, beta, y in rad,
        rad/s, rad, m) or 2 (psi_dot, beta; 4 where ``padded``).
    """
    if n_steps % record_every:
        raise ValueError("n_steps must be a multiple of record_every")
    # one compiled signature: every array float64, C-contiguous and writable (numba types a
    # read-only view apart), the (J, n) wind as it comes when it already is
    own = lambda a: np.require(a, float, ("C", "W"))  # noqa: E731
    F_w_half = own(F_w_half)
    n = F_w_half.shape[1]
    as_n = lambda a: np.array(np.broadcast_to(np.asarray(a, float), (n,)), order="C")  # noqa: E731
    out = np.zeros((n_steps // record_every + 1, 4 if heading or padded else 2, n))
    if padded and not heading:
        out[:, 0] = out[:, 3] = np.nan
    C = np.stack([as_n(a) for a in (P, a12, a13, W1, Q, R, S, inv_m, 0.0 if M_term is None else M_term, a_lat, k)])
    args = (out, float(h), int(n_steps), int(record_every), bool(np.any(a_lat)), M_term is None, C, own(delta_half), F_w_half,
            own(inv_v), own(rate))
    return (_rates_pass if not heading else _exact_course_pass if exact else _heading_pass)(*args)

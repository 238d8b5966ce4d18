"""The compiled RK4 pass of the linear single-track model along a speed profile: every step and
realisation in one numba loop, the numbers of the NumPy right-hand side bit for bit.

numba is imported with this module, which only the integration along a speed profile imports.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = ["rk4_linear_track"]


def _compiled(py_func):
    """``py_func`` compiled at its first call, the machine code cached beside the module (or in
    the user's cache); with no writable place numba refuses to cache: then compiled anew per process."""
    try:
        return njit(cache=True, nogil=True)(py_func)
    except RuntimeError:  # "cannot cache function ...: no locator available"
        return njit(nogil=True)(py_func)


def _rk4_pass(x, out, h, n_steps, record_every, heading, exact, has_lat, yaw_gust,
              P, a12, a13, W1, Q, R, S, inv_m, M_term, a_lat, k, delta_half, F_w_half, inv_v, rate):
    """In place: ``x`` (d, n) advanced ``n_steps``, every ``record_every``-th state into ``out``.

    Per realisation and stage the operations of
    :meth:`uqdrive.vehicle.track_rk4.LinearTrackRHS.__call__` and its ``_inputs``, in their order
    (no fused multiply-add: numba contracts none without fastmath), and the stage sums of
    :func:`uqdrive.numerics.integrate.rk4_fixed_step_into`.
    """
    n = x.shape[1]
    half, sixth = 0.5 * h, h / 6.0
    ir, ib = (1, 2) if heading else (0, 1)
    for i in range(n_steps):
        j = 2 * i
        for m in range(n):
            x0, r0, b0 = x[0, m], x[ir, m], x[ib, m]
            psi, r, b = x0, r0, b0
            acc_r = acc_b = acc_psi = acc_y = 0.0
            k1r = k1b = k1p = k1y = 0.0
            k2r = k2b = k2p = k2y = 0.0
            k3r = k3b = k3p = k3y = 0.0
            for stage in range(4):
                jj = j if stage == 0 else (j + 2 if stage == 3 else j + 1)
                iv, d, F = inv_v[jj], delta_half[jj], F_w_half[jj, m]
                # the state-free terms (LinearTrackRHS._inputs)
                u0 = a13[m] * d
                u2 = S[m] * (d * iv)
                u3 = inv_m[m] * F
                u3 *= iv
                # psi_ddot
                o1 = P[m] * r
                o1 *= iv
                o1 += a12[m] * b
                o1 += u0
                o1 += W1[m] * F if yaw_gust else M_term[m]
                # beta_dot
                o2 = Q[m] * r
                o2 *= iv * iv
                o2 -= r
                t = R[m] * b
                t *= iv
                o2 += t
                o2 -= b * rate[jj]
                o2 += u2
                o2 += u3
                if has_lat:
                    o2 += a_lat[m] * iv
                o0 = o3 = 0.0
                if heading:
                    o0 = r
                    o3 = b * k[m]
                    o3 += psi
                    if exact:
                        o3 = math.sin(o3)
                    o3 /= iv
                if stage == 0:
                    k1r, k1b, k1p, k1y = o1, o2, o0, o3
                    scale = half
                elif stage == 1:
                    k2r, k2b, k2p, k2y = o1, o2, o0, o3
                    scale = half
                elif stage == 2:
                    k3r, k3b, k3p, k3y = o1, o2, o0, o3
                    scale = h
                else:
                    # x + (h / 6) (k1 + 2 (k2 + k3) + k4), in rk4_fixed_step_into's order
                    acc_r = (((k2r + k3r) * 2.0 + k1r) + o1) * sixth
                    acc_b = (((k2b + k3b) * 2.0 + k1b) + o2) * sixth
                    acc_psi = (((k2p + k3p) * 2.0 + k1p) + o0) * sixth
                    acc_y = (((k2y + k3y) * 2.0 + k1y) + o3) * sixth
                    break
                # the next stage's state: h/2 k + x (or h k3 + x), formed as the stepper forms it
                r = o1 * scale + r0
                b = o2 * scale + b0
                psi = o0 * scale + x0
            x[ir, m] = r0 + acc_r
            x[ib, m] = b0 + acc_b
            if heading:
                x[0, m] = x0 + acc_psi
                x[3, m] = x[3, m] + acc_y
        if (i + 1) % record_every == 0:
            out[(i + 1) // record_every] = x
    return out


_rk4_pass = _compiled(_rk4_pass)


def rk4_linear_track(h: float, n_steps: int, record_every: int, *, heading: bool, exact: bool, P, a12, a13, W1, Q, R, S, inv_m, M_term,
                     a_lat, k, delta_half, F_w_half, inv_v, rate):
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
        Mean-wind yaw moment over I_z (rad/s^2); None: the gusts' W1 F_w instead.
    a_lat : float or ndarray, shape (n,)
        Lateral acceleration (m/s^2) of the road (zero: the term is left out, as the NumPy path does).
    k : float or ndarray, shape (n,)
        Course weight of beta in the course angle.
    delta_half : ndarray, shape (J,)
        Actual steering angle (rad) on the half-step grid, J = 2 ``n_steps`` + 1.
    F_w_half : ndarray, shape (J, n)
        Side wind (N) per half step and realisation.
    inv_v, rate : ndarray, shape (J,)
        1 / v (s/m) and v_dot / v (1/s) per half step, as LinearTrackRHS precomputes them.

    Returns
    -------
    ndarray, shape (n_steps // record_every + 1, d, n)
        The states every ``record_every`` steps from t = 0, d = 4 (psi, psi_dot, beta, y in rad,
        rad/s, rad, m) or 2 (psi_dot, beta).
    """
    if n_steps % record_every:
        raise ValueError("n_steps must be a multiple of record_every")
    # one compiled signature: every array float64, C-contiguous and writable (numba types a
    # read-only view apart), the (J, n) wind as it comes when it already is
    own = lambda a: np.require(a, float, ("C", "W"))  # noqa: E731
    F_w_half = own(F_w_half)
    n = F_w_half.shape[1]
    as_n = lambda a: np.array(np.broadcast_to(np.asarray(a, float), (n,)), order="C")  # noqa: E731
    x = np.zeros((4 if heading else 2, n))
    out = np.empty((n_steps // record_every + 1,) + x.shape)
    out[0] = x
    args = (x, out, float(h), int(n_steps), int(record_every), bool(heading), bool(exact), bool(np.any(a_lat)), M_term is None,
            *(as_n(a) for a in (P, a12, a13, W1, Q, R, S, inv_m, 0.0 if M_term is None else M_term, a_lat, k)),
            own(delta_half), F_w_half, own(inv_v), own(rate))
    return _rk4_pass(*args)

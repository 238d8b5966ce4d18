"""The loads-forces loop of the chassis right-hand side compiled: Newton's method on the tyres'
lateral force T, per realisation in one numba loop, the numbers of the NumPy loop bit for bit.

:meth:`uqdrive.vehicle.track_extended.ExtendedSingleTrackRHS._forces` solves T = F_f(P(T)) cos(delta)
+ F_r(P(T)) for the effective axle loads P that T makes (:class:`uqdrive.vehicle.axle_loads.AxleLoads`).
Each step is some hundred operations on (2, n) arrays; at the chassis fits' few thousand
realisations NumPy spends most of their time per call, not per element. The loop here performs
the same operations per realisation in the same order (no fused multiply-add: numba contracts
none without fastmath), so every number is NumPy's; it is used where the loop is arithmetic alone
(the linear tyre, or the Magic Formula at slip angles the loads leave alone). Where the tyre's
stiffness follows its load (the load-sensitive tyre) each step's loads move the curve, whose
arctangents and tangents NumPy takes between compiled steps (:func:`sensitive_newton`).

numba is imported with this module, which the chassis right-hand side imports at its first loop;
each combination of terms is compiled once (about 2 s) and cached on disk.
"""

from __future__ import annotations

import functools

import numpy as np
from numba import njit

from .fused_rates import curvature_from_atan, half_angle_sine, half_tyre_angle, item
from .jit import compiled, factor

__all__ = ["ROWS", "curve_tangent", "newton_loads", "newton_loop", "loads_step", "sensitive_newton", "stepwise_newton"]

#: The rows of the per-realisation constants ``K`` (each shape (n,)): the car's and the structure's.
ROWS = ("m", "a_lat", "h_x", "static_f", "static_r", "arm_f", "arm_r", "p_Dz", "mu", "kappa", "kappa_x", "drive_f", "drive_r",
        "brake_f", "brake_r", "p_D", "q_K", "h_s", "reference_f", "reference_r")
# their indices (constants of the compiled loops)
(M, A_LAT, H_X, STATIC_F, STATIC_R, ARM_F, ARM_R, P_DZ, MU, KAPPA, KAPPA_X, DRIVE_F, DRIVE_R, BRAKE_F, BRAKE_R, P_D, Q_K, H_S,
 REFERENCE_F, REFERENCE_R) = range(len(ROWS))


@njit(error_model="numpy")
def _at_least(x, c):
    """np.maximum(x, c): c where x < c, else x (a NaN stays NaN)."""
    return c if x < c else x


@njit(error_model="numpy")
def _wheel_pair(F_z, dF, F0, p_Dz, half, arm, slope):
    """One axle's effective load P and dP / dT: its inner and outer wheel (F_z / 2 -+ dF, a lifted
    wheel carrying nothing, no peak below zero), each at its peak per unit load (Pacejka (4.E13))."""
    P = dP = 0.0
    for sign in (-1.0, 1.0):
        w = _at_least(0.5 * F_z + sign * dF, 0.0)
        gain = 1.0 + p_Dz * (w - F0) / F0
        P = P + w * _at_least(gain, 0.0)
        if slope:
            d_w = half + sign * arm
            dP = dP + ((gain + p_Dz * w / F0) * d_w if (w > 0) and (gain > 0) else 0.0)
    return P, dP


@njit(inline="always", error_model="numpy")
def _loads(T, i, K, tan_b, cos_b, sin_b, v_dot, F_w, L, pitching, transferring, slope):
    """AxleLoads._loads of realisation ``i`` at the tyres' force ``T``: P_f, P_r and, with
    ``slope``, dP_f / dT, dP_r / dT (``has_slope`` False where NumPy's slope is the scalar 0).

    At held speed (v_dot = 0) NumPy takes a_x = -(tan_b a_y), the general form's value: 0 cos_b
    and 0 sin_b are zeros, which leave a_y and tan_b a_y as they are (at most a zero's sign
    differs, which the loads' sums s + -shift do not keep), so one loop serves both."""
    s_f, s_r = K[STATIC_F, i], K[STATIC_R, i]
    if not pitching:
        raw_f, raw_r = s_f, s_r
        F_zf, F_zr = s_f, s_r
        d_shift = 0.0
    else:
        m = K[M, i]
        a_y = (T + F_w) / m + K[A_LAT, i]
        a_x = v_dot * cos_b - tan_b * (a_y - v_dot * sin_b)
        shift = m * a_x * K[H_X, i] / L
        raw_f, raw_r = s_f + -shift, s_r + shift
        # np.maximum(raw, 0) written so that LLVM vectorises the loops that inline it (as _at_least it did not)
        F_zf, F_zr = raw_f if not (raw_f < 0.0) else 0.0, raw_r if not (raw_r < 0.0) else 0.0
        d_shift = -tan_b * K[H_X, i] / L if slope else 0.0
    if not transferring:
        if not slope or not pitching:
            return F_zf, F_zr, 0.0, 0.0, False
        return F_zf, F_zr, (-d_shift if raw_f > 0 else 0.0), (d_shift if raw_r > 0 else 0.0), True
    arm_f, arm_r, p_Dz = K[ARM_F, i], K[ARM_R, i], K[P_DZ, i]
    dF_f, dF_r = arm_f * T, arm_r * T
    F0_f, F0_r = 0.5 * s_f, 0.5 * s_r
    half_f = half_r = 0.0
    if slope and pitching:
        half_f = 0.5 * -d_shift if raw_f > 0 else 0.0
        half_r = 0.5 * d_shift if raw_r > 0 else 0.0
    P_f, dP_f = _wheel_pair(F_zf, dF_f, F0_f, p_Dz, half_f, arm_f, slope)
    P_r, dP_r = _wheel_pair(F_zr, dF_r, F0_r, p_Dz, half_r, arm_r, slope)
    return P_f, P_r, dP_f, dP_r, slope


@njit(error_model="numpy")
def _capacity(T, i, K, P_f, P_r, tan_b, cos_b, sin_b, v_dot, F_w):
    """AxleLoads.lateral_capacity of realisation ``i`` (the friction ellipse's shares)."""
    m, mu = K[M, i], K[MU, i]
    a_y = (T + F_w) / m + K[A_LAT, i]
    F_x = m * (v_dot * cos_b - tan_b * (a_y - v_dot * sin_b))
    # both pairs loaded, then chosen: a load on one branch only keeps LLVM from vectorising the loop
    drive_f, drive_r, brake_f, brake_r = K[DRIVE_F, i], K[DRIVE_R, i], K[BRAKE_F, i], K[BRAKE_R, i]
    share_f = drive_f if F_x > 0 else brake_f
    share_r = drive_r if F_x > 0 else brake_r
    used_f = K[KAPPA_X, i] * share_f * F_x / _at_least(mu * P_f, 1e-3 * K[STATIC_F, i])
    used_r = K[KAPPA_X, i] * share_r * F_x / _at_least(mu * P_r, 1e-3 * K[STATIC_R, i])
    return np.sqrt(_at_least(1.0 - used_f * used_f, 0.0)), np.sqrt(_at_least(1.0 - used_r * used_r, 0.0))


@njit(error_model="numpy")
def _factors(T, i, K, tan_b, cos_b, sin_b, v_dot, F_w, L):
    """AxleLoads.load_factors of realisation ``i``: the peak's and the stiffness' factors per axle."""
    m = K[M, i]
    a_x = v_dot * cos_b - tan_b * ((T + F_w) / m + K[A_LAT, i] - v_dot * sin_b)
    shift = m * a_x * K[H_S, i] / L
    ref_f, ref_r = K[REFERENCE_F, i], K[REFERENCE_R, i]
    dfz_f = (K[STATIC_F, i] + -shift - ref_f) / ref_f
    dfz_r = (K[STATIC_R, i] + shift - ref_r) / ref_r
    p_D, q_K = K[P_D, i], K[Q_K, i]
    return (_at_least(1.0 + p_D * dfz_f, 0.05), _at_least(1.0 + p_D * dfz_r, 0.05),
            _at_least(1.0 + q_K * dfz_f, 0.05), _at_least(1.0 + q_K * dfz_r, 0.05))


@njit(inline="always", error_model="numpy")
def _one_pass(T, K, tan_b, cos_b, sin_b, front, slip, unit, F_w, P, capacity, factors, v_dot, L, B_f, B_r, C,
              pitching, transferring, slipping, sensitive, saturating, yielding, slope):
    """One pass of the loads' loop over the realisations: a Newton step of T (``slope``) or the
    loads, shares and factors of the converged T stored (not ``slope``). Inlined where a loop of
    :func:`_kernel` calls it with its constant terms, which fold away before LLVM vectorises it."""
    for i in range(T.shape[0]):
        t = T[i]
        tb, cb, sb, fw = tan_b[i], cos_b[i], sin_b[i], F_w[i]
        P_f, P_r, dP_f, dP_r, has_slope = _loads(t, i, K, tb, cb, sb, v_dot, fw, L, pitching, transferring, slope)
        c_f = c_r = 1.0
        if slipping:
            c_f, c_r = _capacity(t, i, K, P_f, P_r, tb, cb, sb, v_dot, fw)
        f0_f = f0_r = f1_f = f1_r = 1.0
        if sensitive:
            f0_f, f0_r, f1_f, f1_r = _factors(t, i, K, tb, cb, sb, v_dot, fw, L)
        if not slope:  # the loads of the converged T: the caller's _at_loads takes them
            P[0, i], P[1, i] = P_f, P_r
            capacity[0, i], capacity[1, i] = c_f, c_r
            factors[0, i], factors[1, i], factors[2, i], factors[3, i] = f0_f, f0_r, f1_f, f1_r
            continue
        mu = K[MU, i]
        peak_f, peak_r = P_f * mu, P_r * mu
        if slipping:
            peak_f, peak_r = peak_f * c_f, peak_r * c_r
        B_f_i, B_r_i, C_i = item(B_f, i), item(B_r, i), item(C, i)
        b_f, b_r = B_f_i, B_r_i
        if sensitive:
            peak_f, peak_r = peak_f * f0_f, peak_r * f0_r
            b_f, b_r = B_f_i * (f1_f / f0_f), B_r_i * (f1_r / f0_r)
        q_f, q_r = slip[0, i], slip[1, i]
        if saturating:
            F_f, F_r = peak_f * unit[0, i], peak_r * unit[1, i]
        else:
            if yielding:  # linear tyre, the front wheels yielding to their force: q0 / (1 + kappa c)
                q_f = q_f / _at_least(1.0 + K[KAPPA, i] * (peak_f * b_f * C_i), 0.05)
            F_f, F_r = peak_f * b_f * C_i * q_f, peak_r * b_r * C_i * q_r
        dF_f = F_f / _at_least(P_f, 1e-3 * K[STATIC_F, i])
        dF_r = F_r / _at_least(P_r, 1e-3 * K[STATIC_R, i])
        if yielding:
            dF_f /= 1.0 + K[KAPPA, i] * P_f * mu * B_f_i * C_i
        fr = front[i]
        if has_slope:
            gain = fr * dF_f * dP_f + dF_r * dP_r
            T[i] = t + (fr * F_f + F_r - t) / _at_least(1.0 - gain, 0.05)
        else:  # NumPy's scalar slope 0: max(1 - 0, 0.05)
            T[i] = t + (fr * F_f + F_r - t) / 1.0


@functools.lru_cache(maxsize=None)
def _kernel(pitching: bool, transferring: bool, slipping: bool, sensitive: bool, saturating: bool, yielding: bool):
    """The loop of ExtendedSingleTrackRHS._forces for one combination of terms (see :func:`newton_loads`).

    The terms are constants of the compiled loop, not arguments: a branch on an argument inside
    the loop over realisations keeps LLVM from vectorising it (4x slower). So is the kind of pass:
    the Newton steps (T updated) and the final pass (the loads stored) are loops of their own
    (:func:`_one_pass` inlined twice); in one loop that branched on the step, LLVM vectorised only
    the lateral transfer alone (the other combinations several times slower:
    benchmarks/bench_load_loop.py). Each combination is compiled at its first use and cached on
    disk (numba keys a closure's cache by its values; its cells are the terms alone, no compiled
    loop: :func:`.jit.calls_closures`)."""

    def loop(T, K, tan_b, cos_b, sin_b, front, slip, unit, F_w, P, capacity, factors, steps, v_dot, L, B_f, B_r, C):
        for _ in range(steps):
            _one_pass(T, K, tan_b, cos_b, sin_b, front, slip, unit, F_w, P, capacity, factors, v_dot, L, B_f, B_r, C,
                      pitching, transferring, slipping, sensitive, saturating, yielding, True)
        _one_pass(T, K, tan_b, cos_b, sin_b, front, slip, unit, F_w, P, capacity, factors, v_dot, L, B_f, B_r, C,
                  pitching, transferring, slipping, sensitive, saturating, yielding, False)

    return compiled(loop)


def newton_loads(T, K, trig, front, slip, unit, F_w, steps: int, v_dot: float, L: float, B_f, B_r, C, *,
                 pitching: bool, transferring: bool, slipping: bool, sensitive: bool, yielding: bool):
    """Newton's method on the tyres' lateral force T (N) of the chassis right-hand side, and the
    loads of its result.

    Per realisation the operations of the loop in
    :meth:`uqdrive.vehicle.track_extended.ExtendedSingleTrackRHS._forces` with
    :meth:`~uqdrive.vehicle.axle_loads.AxleLoads._loads`, ``lateral_capacity``, ``load_factors`` and
    ``_at_loads`` (Rajamani eq. (2.27), Gillespie eq. (2-4), Pacejka (4.E13)), in their order:
    ``steps`` steps T <- T + (front F_f + F_r - T) / max(1 - d(front F_f + F_r)/dT, 0.05), then the
    loads at the last T.

    Parameters
    ----------
    T : ndarray, shape (n,)
        The steady guess (N), overwritten by the loop's result.
    K : ndarray, shape (len(ROWS), n)
        Per-realisation constants, rows :data:`ROWS` (kg, m/s^2, m, N, N, m/m, m/m, -, -, rad/N, -, -, -, -, -, -, -, m, N, N).
    trig : ndarray, shape (3, n)
        tan, cos and sin of the side slip beta (-).
    front : ndarray, shape (n,)
        cos of the front wheel angle (Magic Formula) or 1 (linear tyre) (-).
    slip : ndarray, shape (2, n)
        Slip angles (rad) whose force the loads scale: the lagged ones of a relaxing tyre, else the steady ones.
    unit : ndarray, shape (2, n)
        The Magic Formula's force per unit peak at ``slip`` (-); ignored for the linear tyre (``unit`` of zero rows).
    F_w : ndarray, shape (n,)
        Side wind (N) at the half step.
    steps : int
        Newton steps (:data:`uqdrive.vehicle.track_extended.LOAD_NEWTON_STEPS`).
    v_dot, L : float
        Speed rate (m/s^2) and wheelbase (m).
    B_f, B_r, C : float or ndarray, shape (n,)
        Stiffness factors (-) and shape factor (-), one for all realisations or each its own.
    pitching, transferring, slipping, sensitive, yielding : bool
        Longitudinal transfer, lateral transfer (or load-sensitive peak), combined slip,
        load-sensitive tyre, front wheels yielding to their steady force (linear tyre only).

    Returns
    -------
    P, capacity, factors : ndarray, shapes (2, n), (2, n), (4, n)
        The effective axle loads (N), the lateral shares the longitudinal force leaves (-), and
        the peak's and stiffness' factors (front, rear each) (-) at the returned T.
    """
    n = T.shape[0]
    P, capacity, factors = np.empty((2, n)), np.empty((2, n)), np.empty((4, n))
    loop = newton_loop(bool(pitching), bool(transferring), bool(slipping), bool(sensitive), unit.shape[0] == 2, bool(yielding))
    loop(T, K, trig[0], trig[1], trig[2], front, slip, unit, F_w, P, capacity, factors, int(steps), float(v_dot), float(L), factor(B_f, n),
         factor(B_r, n), factor(C, n))
    return P, capacity, factors


def newton_loop(pitching: bool, transferring: bool, slipping: bool, sensitive: bool, saturating: bool, yielding: bool):
    """The compiled loop :func:`newton_loads` calls for one combination of terms, for a caller that
    keeps its output arrays between calls (a right-hand side called four times a step).

    Parameters
    ----------
    pitching, transferring, slipping, sensitive, yielding : bool
        As :func:`newton_loads`.
    saturating : bool
        The Magic Formula (``unit`` has two rows), else the linear tyre.

    Returns
    -------
    callable
        ``loop(T, K, tan_b, cos_b, sin_b, front, slip, unit, F_w, P, capacity, factors, steps, v_dot, L, B_f, B_r, C)``:
        the arguments of :func:`newton_loads` (``trig``'s rows apart), writing T, P, capacity and factors in place.
    """
    return _kernel(pitching, transferring, slipping, sensitive, saturating, yielding)


def curve_tangent(bx, E, C, work) -> None:
    """tan of half the Magic Formula's angle C atan(u), u = B x - E (B x - atan(B x)), into ``bx``
    (2, n), which holds B x (-): :func:`uqdrive.vehicle.single_track.curvature_argument`'s and
    :func:`uqdrive.vehicle.axle_loads.half_angle_sin_cos`'s order, NumPy's arctan and tan.
    ``C`` a float or (n,) (:func:`.jit.factor`), ``E`` (n,) the curvature factor, ``work`` (2, n) overwritten."""
    np.arctan(bx, work)
    curvature_from_atan(bx, E, work)
    np.arctan(work, work)
    half_tyre_angle(work, C, bx)
    np.tan(bx, bx)


@functools.lru_cache(maxsize=None)
def loads_step(pitching: bool, transferring: bool, slipping: bool, sensitive: bool):
    """The compiled step of the loads at T (N), per realisation, for one combination of terms
    (constants of the loop, folded before LLVM vectorises it): ``loads_step(T, K, tan_b, cos_b,
    sin_b, slip, F_w, slope, v_dot, L, B_f, B_r, P, dP, peak, bx, capacity, factors)`` writes the
    loads P (N), with ``slope`` their slope dP / dT (-), the peaks mu P c (N) and the lateral shares
    c (-); with ``sensitive`` the factors (-), the peaks times f_D and B f_K / f_D times the slip
    angles ``slip`` into ``bx`` (:func:`sensitive_newton`'s and :mod:`.fused_yield`'s loops)."""

    def step(T, K, tan_b, cos_b, sin_b, slip, F_w, slope, v_dot, L, B_f, B_r, P, dP, peak, bx, capacity, factors):
        for i in range(T.shape[0]):
            t = T[i]
            tb, cb, sb, fw = tan_b[i], cos_b[i], sin_b[i], F_w[i]
            P_f, P_r, dP_f, dP_r, _ = _loads(t, i, K, tb, cb, sb, v_dot, fw, L, pitching, transferring, slope)
            c_f = c_r = 1.0
            if slipping:
                c_f, c_r = _capacity(t, i, K, P_f, P_r, tb, cb, sb, v_dot, fw)
            f0_f = f0_r = f1_f = f1_r = 1.0
            if sensitive:
                f0_f, f0_r, f1_f, f1_r = _factors(t, i, K, tb, cb, sb, v_dot, fw, L)
            mu = K[MU, i]
            peak_f, peak_r = P_f * mu, P_r * mu
            if slipping:
                peak_f, peak_r = peak_f * c_f, peak_r * c_r
            if sensitive:
                peak_f, peak_r = peak_f * f0_f, peak_r * f0_r
                bx[0, i] = (item(B_f, i) * (f1_f / f0_f)) * slip[0, i]
                bx[1, i] = (item(B_r, i) * (f1_r / f0_r)) * slip[1, i]
            peak[0, i], peak[1, i] = peak_f, peak_r
            P[0, i], P[1, i], dP[0, i], dP[1, i] = P_f, P_r, dP_f, dP_r
            capacity[0, i], capacity[1, i] = c_f, c_r
            factors[0, i], factors[1, i], factors[2, i], factors[3, i] = f0_f, f0_r, f1_f, f1_r

    return compiled(step)


@compiled
def _newton_step(T, K, front, P, dP, peak, t, has_slope):
    """One Newton step T <- T + (front F_f + F_r - T) / max(1 - d(front F_f + F_r)/dT, 0.05) from
    the forces peak sin(angle) (``t``: tan of the half angles) (:func:`.load_newton.newton_loads`' order)."""
    for i in range(T.shape[0]):
        F_f = peak[0, i] * half_angle_sine(t[0, i])
        F_r = peak[1, i] * half_angle_sine(t[1, i])
        dF_f = F_f / _at_least(P[0, i], 1e-3 * K[STATIC_F, i])
        dF_r = F_r / _at_least(P[1, i], 1e-3 * K[STATIC_R, i])
        fr, x = front[i], T[i]
        if has_slope:
            gain = fr * dF_f * dP[0, i] + dF_r * dP[1, i]
            T[i] = x + (fr * F_f + F_r - x) / _at_least(1.0 - gain, 0.05)
        else:  # NumPy's scalar slope 0: max(1 - 0, 0.05)
            T[i] = x + (fr * F_f + F_r - x) / 1.0


def sensitive_newton(T, K, trig, front, slip, F_w, steps: int, v_dot: float, L: float, B_f, B_r, C, E, out,
                     *, pitching: bool, transferring: bool, slipping: bool) -> None:
    """Newton's method on the tyres' lateral force T (N) of a Magic-Formula chassis model with the
    load-sensitive tyre, and its forces' peaks and curve at the result.

    Per realisation the operations of the NumPy loop in
    :meth:`uqdrive.vehicle.track_extended.ExtendedSingleTrackRHS._forces` (Rajamani eq. (2.27),
    Gillespie eq. (2-4), Pacejka (4.E13)-(4.E14)): ``steps`` steps of :func:`.load_newton.newton_loads`'
    update with the stiffness B f_K / f_D and the peak mu P f_D of the step's loads, then the loads
    at the last T.

    Parameters
    ----------
    T : ndarray, shape (n,)
        The steady guess (N), overwritten by the loop's result.
    K : ndarray, shape (len(ROWS), n)
        Per-realisation constants, rows :data:`ROWS` (kg, m/s^2, m, N, N, m/m, m/m, -, -, rad/N, -, -, -, -, -, -, -, m, N, N).
    trig : ndarray, shape (3, n)
        tan, cos and sin of the side slip beta (-).
    front : ndarray, shape (n,)
        cos of the front wheel angle (-).
    slip : ndarray, shape (2, n)
        The slip angles the forces follow (rad): the lagged ones of a relaxing tyre, else the steady ones.
    F_w : ndarray, shape (n,)
        Side wind (N) at the half step.
    steps : int
        Newton steps (:data:`uqdrive.vehicle.track_extended.LOAD_NEWTON_STEPS`).
    v_dot, L : float
        Speed rate (m/s^2) and wheelbase (m).
    B_f, B_r, C : float or ndarray, shape (n,)
        The load-free stiffness factors (-) and the shape factor (-) (:func:`.jit.factor`).
    E : ndarray, shape (n,)
        The curvature factor (-).
    out : tuple of ndarray
        Work arrays ``(P, dP, peak, t, capacity, factors, work)``, shapes (2, n) but factors (4, n):
        at return ``peak`` holds the axles' peaks mu P c f_D (N) and ``t`` the tangents of the
        curve's half angles at the result (the force is peak sin(angle)).
    pitching, transferring, slipping : bool
        Longitudinal transfer, lateral transfer, combined slip.
    """
    P, dP, peak, t, capacity, factors, work = out
    stepwise_newton(T, K, trig, slip, F_w, steps, v_dot, L, B_f, B_r, (P, dP, peak, t, capacity, factors), lambda: curve_tangent(t, E, C, work),
                    lambda has_slope: _newton_step(T, K, front, P, dP, peak, t, has_slope), pitching=pitching, transferring=transferring,
                    slipping=slipping, sensitive=True)


def stepwise_newton(T, K, trig, slip, F_w, steps: int, v_dot: float, L: float, B_f, B_r, work, between, update, *,
                    pitching: bool, transferring: bool, slipping: bool, sensitive: bool) -> None:
    """Newton's method on the tyres' lateral force T (N) one step at a time, for a tyre whose
    curve the loads move (:func:`sensitive_newton`, :func:`.fused_yield.yielding_newton`): at each
    of ``steps`` steps :func:`loads_step` into ``work`` = ``(P, dP, peak, bx, capacity, factors)``
    (the arguments of :func:`sensitive_newton`, N and -), ``between()`` (the curve at those loads),
    ``update(has_slope)`` (the compiled Newton update of T); then the loads and ``between()`` at the last T."""
    P, dP, peak, bx, capacity, factors = work
    kernel = loads_step(bool(pitching), bool(transferring), bool(slipping), bool(sensitive))
    tan_b, cos_b, sin_b = trig
    has_slope = bool(transferring or pitching)
    for step in range(steps + 1):
        slope = step < steps
        kernel(T, K, tan_b, cos_b, sin_b, slip, F_w, slope, float(v_dot), float(L), B_f, B_r, P, dP, peak, bx, capacity, factors)
        between()
        if slope:
            update(has_slope)


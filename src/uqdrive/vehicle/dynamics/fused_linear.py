"""The chassis right-hand side on the linear tyre, compiled: the rates of
:class:`uqdrive.vehicle.track_extended.ExtendedSingleTrackRHS` on the LST's kinematics in one loop, bit for bit.

On the linear tyre the chassis rates are arithmetic alone (small slip angles, F = c alpha, the
course psi + k beta), some 35 NumPy calls on (n,) and (2, n) arrays whose per-call cost is most of
a step at the few hundred realisations of a discover fit. Here they run as one loop per
realisation in the NumPy path's order (no multiply-add contraction without fastmath), so every
number is the NumPy path's. Served: tyre relaxation, roll steer and compliance steer, on static
loads or on loads that follow the tyres' force (load transfer, combined slip, the load-sensitive
tyre: the loop is :func:`.load_newton.newton_loads`, between two loops here).
"""

from __future__ import annotations

import functools

import numpy as np

from numba import njit

from .fused_chassis import ChassisConstants, chassis_arguments, course_sine_into, load_guess_at, near_sine, roll_mode_at
from .fused_rates import half_angle_pair, item
from .jit import compiled, realisations

__all__ = ["FusedLinearChassisRates", "fused_linear_chassis_rates"]


@njit(inline="always", error_model="numpy")
def _steady_slip_at(x, i, lever, v, delta, i_roll):
    """Realisation ``i``'s steady slip angles -(beta + lever psi_dot / v), the front's plus delta
    minus the roll steer (rows ``i_roll``; 0: none) (track_extended.ExtendedSingleTrackRHS.steady_slip)."""
    psi_dot, beta = x[1, i], x[2, i]
    a_f = lever[0, i] * psi_dot
    a_f = a_f / v
    a_f = beta + a_f
    a_f = -a_f
    a_r = lever[1, i] * psi_dot
    a_r = a_r / v
    a_r = beta + a_r
    a_r = -a_r
    a_f = a_f + item(delta, i)
    if i_roll > 0:
        a_f = a_f - x[i_roll, i]
    return a_f, a_r


@functools.lru_cache(maxsize=None)
def _load_guess(relaxed: bool, i_roll: int):
    """The loop that readies the loads' Newton loop, for tyres that relax or not and the roll
    steer's first state row ``i_roll`` (0: none), constants of the compiled loop as in
    :func:`_linear_kernel` (as arguments they kept it from vectorising: 10.5 -> 3.2 us a call at 300
    realisations). From t = tan(beta / 2): cos and sin of beta (axle_loads.half_angle_sin_cos)
    into rows 1 and 2 of ``trig``, the loads' steady guess T = m (v psi_dot cos beta + v' sin beta
    - a_lat) - F_w into ``T`` and the slip angles whose force the loads scale (the lagged states
    where sigma > 0, else the steady ones) into ``slip`` (2, n)."""

    def guess(t, trig, x, lever, v, delta, sigma, m, v_dot, a_lat, F_w, T, slip):
        for i in range(t.shape[0]):
            s, c = half_angle_pair(t[i])
            trig[1, i] = c
            trig[2, i] = s
            T[i] = load_guess_at(i, x[1, i], s, c, v, v_dot, m, a_lat, F_w)
            a_f, a_r = _steady_slip_at(x, i, lever, v, delta, i_roll)
            if relaxed and item(sigma, i) > 0:
                a_f, a_r = x[4, i], x[5, i]
            slip[0, i] = a_f
            slip[1, i] = a_r

    return compiled(guess)


@functools.lru_cache(maxsize=None)
def _linear_kernel(relaxed: bool, i_roll: int):
    """The loop of the LST's chassis rates (track_extended.ExtendedSingleTrackRHS.__call__ on the
    linear tyre) for tyres that relax or not and the roll steer's first state row ``i_roll`` (0:
    none), constants of the compiled loop: as arguments, a state row and the branches on them keep
    LLVM from vectorising it (3-5x slower at 2400 realisations). Each combination is compiled at its
    first use and cached on disk (numba keys a closure's cache by its values).

    The loop writes dx/dt into ``out``: the slip angles -(beta + lever psi_dot / v), the front's
    plus delta minus the roll steer; the axle forces ((mu P capacity f_D) B f_K / f_D) C alpha on the
    loads ``P`` (2, n), with the lateral shares ``capacity`` and the load-sensitive tyre's
    ``factors`` [f_D; f_K] (4, n) where they have rows (``stiffness`` [B_f, B_r, C], applied in the
    path's order), of the lagged slip where sigma > 0, the front wheels yielding to their force
    where ``compliant`` (alpha_f / max(1 + kappa c_f, 0.05) without relaxation, the steady front
    slip minus kappa F_f with it); the lagged states' (alpha_ss - alpha) v / sigma, the roll mode,
    psi_dot, the balances and the course psi + k beta (row 3; ``scaled``: v times it, else the
    caller takes its sine); the force across the car F_f + F_r + F_w (N) into ``total`` (n,)."""
    rolling = i_roll > 0

    def rates(x, out, lever, P, capacity, factors, mu, stiffness, v, delta, sigma, kappa, compliant, omega, gain, zeta, l_f, l_r, F_w,
              M_c, M_w, has_M_w, yaw_factor, inv_mv, a_v, v_dot_v, has_v_dot, k, scaled, total):
        B_f, B_r, C = stiffness[0], stiffness[1], stiffness[2]
        capped, factored = capacity.shape[0] > 0, factors.shape[0] > 0
        for i in range(x.shape[1]):
            psi_dot, beta, x0 = x[1, i], x[2, i], x[0, i]
            a_f, a_r = _steady_slip_at(x, i, lever, v, delta, i_roll)
            mu_i = item(mu, i)
            c_f = P[0, i] * mu_i
            c_r = P[1, i] * mu_i
            b_f, b_r = B_f, B_r
            if capped:
                c_f = c_f * capacity[0, i]
                c_r = c_r * capacity[1, i]
            if factored:
                c_f = c_f * factors[0, i]
                c_r = c_r * factors[1, i]
                b_f = b_f * (factors[2, i] / factors[0, i])
                b_r = b_r * (factors[3, i] / factors[1, i])
            c_f = c_f * b_f
            c_f = c_f * C
            c_r = c_r * b_r
            c_r = c_r * C
            lagging = relaxed and item(sigma, i) > 0
            s_f, s_r = (x[4, i], x[5, i]) if lagging else (a_f, a_r)
            if compliant and not relaxed:
                den = item(kappa, i) * c_f
                den = 1.0 + den
                den = 0.05 if den < 0.05 else den
                s_f = a_f / den
                a_f = s_f
            F_f = c_f * s_f
            F_r = c_r * s_r
            if compliant and relaxed:
                a_f = a_f - item(kappa, i) * F_f
            if relaxed:
                s = item(sigma, i)
                s = s if s > 0 else np.inf
                d = a_f - x[4, i]
                d = d * v
                out[4, i] = d / s
                d = a_r - x[5, i]
                d = d * v
                out[5, i] = d / s
            if rolling:
                roll_mode_at(x, out, i, i_roll, omega, gain, zeta, F_f + F_r)
            # the balances written out, not fused_chassis' (an inlined helper taking cos beta as 1.0
            # kept LLVM from vectorising this loop: 2.4x slower at 2400 realisations)
            out[0, i] = psi_dot
            F_wi = F_w[i]
            yaw = item(l_f, i) * F_f
            yaw = yaw - item(l_r, i) * F_r
            yaw = yaw + (item(M_w, i) if has_M_w else F_wi * item(M_c, i))
            out[1, i] = yaw * item(yaw_factor, i)
            lateral = F_f + F_r
            lateral = lateral + F_wi
            total[i] = lateral
            lateral = lateral * item(inv_mv, i)
            lateral = lateral - psi_dot
            lateral = lateral + item(a_v, i)
            if has_v_dot:
                lateral = lateral - v_dot_v * beta
            out[2, i] = lateral
            course = x0 + item(k, i) * beta
            out[3, i] = v * course if scaled else course

    return compiled(rates)


class FusedLinearChassisRates(ChassisConstants):
    """:meth:`uqdrive.vehicle.track_extended.ExtendedSingleTrackRHS.__call__` of a chassis model on
    the linear tyre, the same numbers: its constants and work arrays for ``n`` realisations.

    Parameters
    ----------
    B, C : tuple of two floats, float
        The front and rear stiffness factors and the shape factor (-).
    kappa : float or ndarray, shape (n,), or None
        Compliance steer where the front wheels yield to their force: front wheel angle (rad) per newton of the front axle's force.
    course_sine : bool
        y_dot = v sin(psi + k beta) (``course_exact``), else v (psi + k beta).
    **constants
        Those of :class:`.fused_chassis.ChassisConstants`.
    """

    def __init__(self, B, C, kappa, course_sine: bool, **constants):
        super().__init__(**constants)
        n = self.n
        self.stiffness = np.array([B[0], B[1], C], float)
        self.compliant = kappa is not None
        self.kappa = realisations(0.0 if kappa is None else kappa, n)
        self.course_sine = bool(course_sine)
        self.kernel = _linear_kernel(self.relaxed, int(self.i_roll))
        self.guess = _load_guess(self.relaxed, int(self.i_roll))

    def __call__(self, x, out, delta, cos_delta, F_w, M_w, v: float, v_dot: float, inv_mv, a_v, profile: bool) -> None:
        """dx/dt of ``x`` into ``out`` (n_states, n), float64, from one half step's wheel angle
        ``delta`` (rad, a float or (n,); ``cos_delta`` unused: the LST's front force is F_f), side
        wind ``F_w`` (n,) (N), wind moment ``M_w`` (n,) (N m; None: M_c F_w), speed ``v`` (m/s) and
        its rate (m/s^2), 1 / (m v) and a_lat / v; ``profile``: the speed follows a profile
        (beta_dot's -(v' / v) beta)."""
        n = self.n
        if x.shape[1] != n or out.shape != x.shape:  # the compiled loops index without bounds checks
            raise ValueError(f"states of shape {x.shape} (out {out.shape}) for rates built for {n} realisations")
        F_w = realisations(F_w, n)
        P, capacity, factors = self.static, self.none, self.none
        if self.loads is not None:
            a, trig, t = self.loads, self.trig, self.t
            np.multiply(x[2], 0.5, t)
            np.tan(t, t)
            self.guess(t, trig, x, self.lever, v, delta, self.sigma, self.m, v_dot, self.a_lat, F_w, self.T, self.slip)
            if a["pitching"] or a["slipping"] or a["sensitive"]:
                np.tan(x[2], trig[0])
            P, capacity, factors = self.newton_loads(self.ones, self.none, F_w, v_dot, *self.stiffness, self.compliant and not self.relaxed)
            capacity = capacity if a["slipping"] else self.none
            factors = factors if a["sensitive"] else self.none
        exact = self.course_sine
        self.kernel(x, out, self.lever, P, capacity, factors, self.mu, self.stiffness, v, delta, self.sigma, self.kappa, self.compliant,
                    self.omega, self.gain, self.zeta, self.l_f, self.l_r, F_w, self.M_c, 0.0 if M_w is None else realisations(M_w, n),
                    M_w is not None, self.yaw_factor, inv_mv, a_v, v_dot / v, profile, self.k, not exact, self.total)
        if exact:  # axle_loads.course_sine times v: the half-angle sine within 3 rad, NumPy's beyond
            course, t = out[3], self.t
            np.multiply(course, 0.5, t)
            np.tan(t, t)
            if not near_sine(course, t, v):
                course_sine_into(course, t, v, True)


def fused_linear_chassis_rates(rhs, x, steps: int, compiled_loop: bool):
    """:class:`FusedLinearChassisRates` of the chassis right-hand side ``rhs``
    (:class:`uqdrive.vehicle.track_extended.ExtendedSingleTrackRHS`) for states ``x`` (n_states, n),
    or None where it does not serve: the Magic Formula, a loads' loop not compiled
    (``compiled_loop``), constants :func:`.fused_chassis.chassis_arguments` refuses. ``steps``: the loads' Newton steps."""
    if rhs.saturating or (rhs.loaded and not compiled_loop) or np.shape(rhs.B) != (2, 1) or np.ndim(rhs.C):  # one tyre for all
        return None
    constants = chassis_arguments(rhs, x, steps, (rhs.kappa,))
    if constants is None:
        return None
    return FusedLinearChassisRates(rhs.B[:, 0], rhs.C, rhs.kappa if rhs.compliant else None, rhs.course_sine, **constants)

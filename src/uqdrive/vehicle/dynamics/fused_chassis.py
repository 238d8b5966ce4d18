"""The chassis right-hand side's arithmetic between its transcendental calls, compiled: the
Magic-Formula rates of :class:`uqdrive.vehicle.track_extended.ExtendedSingleTrackRHS` with tyre
relaxation, roll steer and the loads' loop in some fifteen calls instead of ~70, bit for bit.

As :mod:`.fused_rates` does for the single-track model: NumPy's SIMD tangents and arctangents stay,
the arithmetic between them runs per realisation in the chassis path's order (no multiply-add
contraction without fastmath), and the loads' Newton loop is :func:`.load_newton.newton_loads`.
Served: the Magic Formula, its stiffness following the loads (the load-sensitive tyre: the loads'
loop step by step, :func:`.load_newton.sensitive_newton`), its wheels yielding to their force
(compliance steer, its Newton loop through the tyre's sine :mod:`.fused_yield`) without
relaxation, on static loads or at each step of the loads' loop
(:func:`.fused_yield.yielding_newton`) but beside the load-sensitive tyre; the right-hand side
keeps NumPy's path elsewhere.
The constants, the roll mode and the loads' steady guess are shared with the linear tyre's loop
(:mod:`.fused_linear`).
"""

from __future__ import annotations

import numpy as np

from numba import njit

from .fused_rates import half_angle_sine, item, side_slip_at
from .fused_yield import FrontYield, yielding_newton
from .jit import compiled, factor, realisations
from .load_newton import curve_tangent, newton_loop, sensitive_newton

__all__ = ["ChassisConstants", "FusedChassisRates", "chassis_arguments", "course_sine_into", "fused_chassis_rates", "load_guess_at", "near_sine",
           "roll_mode_at"]


@njit(inline="always", error_model="numpy")
def roll_mode_at(x, out, i, i_roll, omega, gain, zeta, lateral):
    """Realisation ``i`` of the roll steer's states (rows ``i_roll``, ``i_roll`` + 1): eps' = rate,
    rate' = omega^2 (gain T - eps) - 2 zeta omega rate, T = ``lateral`` the tyres' force (N)."""
    w, eps, rate = item(omega, i), x[i_roll, i], x[i_roll + 1, i]
    out[i_roll, i] = rate
    a = item(gain, i) * lateral
    a = a - eps
    ww = w * w
    a = ww * a
    b = 2.0 * item(zeta, i)
    b = b * w
    b = b * rate
    out[i_roll + 1, i] = a - b


@njit(error_model="numpy")
def load_guess_at(i, psi_dot, s, c, v, v_dot, m, a_lat, F_w):
    """Realisation ``i`` of the loads' steady guess T = m (v psi_dot cos beta + v' sin beta - a_lat)
    - F_w (N) from sin and cos of beta (track_extended.ExtendedSingleTrackRHS._forces' order)."""
    g = v * psi_dot
    g = g * c
    g = g + v_dot * s
    g = g - item(a_lat, i)
    g = item(m, i) * g
    return g - F_w[i]


@compiled
def _side_slip(t, sin_b, cos_b, lever, psi_dot, v, q, loaded, T, m, v_dot, a_lat, F_w, wheel, delta, eps, half_wheel):
    """From t = tan(beta / 2): sin and cos of beta (axle_loads.half_angle_sin_cos) and the slip
    angles' arctan argument (lever psi_dot + v sin beta) / (v cos beta) into ``q`` (2, n); where
    ``loaded``, the loads' steady guess T = m (v psi_dot cos beta + v' sin beta - a_lat) - F_w; where
    ``wheel``, half the wheel angle delta - eps (``eps`` the roll steer) into ``half_wheel``."""
    for i in range(t.shape[0]):
        s, c = side_slip_at(t, i, sin_b, cos_b, lever, psi_dot, v, q)
        if loaded:
            T[i] = load_guess_at(i, psi_dot[i], s, c, v, v_dot, m, a_lat, F_w)
        if wheel:
            d = item(delta, i)
            if eps.shape[0]:
                d = d - eps[i]
            half_wheel[i] = d * 0.5


@compiled
def _slip_angles(q, delta, eps, lag, sigma, B_f, B_r, steady, slip, bx, wheel, half_wheel, cos_delta):
    """From q = atan(argument): the steady slip angles -q, the front's plus delta minus the roll
    steer ``eps`` (none where it has no rows), into ``steady``; the ones the tyres' force follows
    (the lagged states ``lag`` where sigma > 0, else the steady) into ``slip`` and B times them into
    ``bx``; where ``wheel``, cos of the wheel angle from its half angle's tangent into ``cos_delta``."""
    rolling, relaxed = eps.shape[0] > 0, lag.shape[0] > 0
    for i in range(q.shape[1]):
        a_f = -q[0, i]
        a_f = a_f + item(delta, i)
        if rolling:
            a_f = a_f - eps[i]
        a_r = -q[1, i]
        steady[0, i] = a_f
        steady[1, i] = a_r
        if relaxed and item(sigma, i) > 0:
            a_f, a_r = lag[0, i], lag[1, i]
        slip[0, i] = a_f
        slip[1, i] = a_r
        bx[0, i] = item(B_f, i) * a_f
        bx[1, i] = item(B_r, i) * a_r
        if wheel:
            t = half_wheel[i]
            t2 = t * t
            inv = t2 + 1.0
            inv = 1.0 / inv
            cos_delta[i] = (1.0 - t2) * inv


@compiled
def _unit_forces(t, unit):
    """The force per unit peak sin(angle) (2, n) into ``unit`` from t = tan(angle / 2)."""
    for i in range(t.shape[1]):
        for r in range(2):
            unit[r, i] = half_angle_sine(t[r, i])


@compiled
def _rates(unit, from_tangent, P, mu, capacity, cos_delta, x, out, steady, sigma, v, cos_b, sin_b, i_roll, omega, gain, zeta,
           l_f, l_r, F_w, M_c, M_w, has_M_w, yaw_factor, inv_mv, a_v, v_dot_v, has_v_dot, k, total):
    """The axle forces P mu capacity sin(angle) (``unit``: the sine, or with ``from_tangent`` the
    half angle's tangent) and dx/dt into ``out``: the lagged slip angles' (alpha_ss - alpha) v cos(beta)
    / sigma (rows 4-5 where ``steady`` has rows), the roll steer's mode (rows ``i_roll``, ``i_roll`` + 1
    where ``i_roll`` > 0), psi_dot, the yaw and lateral balances (rhs.Balance.rates with a_lat / v and
    -(v' / v) sin beta), and the course angle psi + k beta (row 3, its sine taken after); the force
    across the car F_f cos(delta) + F_r + F_w (N) into ``total`` (n,). Returns whether the course may
    not take the half-angle sine: some |angle| not below 3 rad (NaN included)."""
    relaxed, capped = steady.shape[0] > 0, capacity.shape[0] > 0
    far = False
    for i in range(x.shape[1]):
        mu_i = item(mu, i)
        u_f, u_r = unit[0, i], unit[1, i]
        if from_tangent:
            u_f, u_r = half_angle_sine(u_f), half_angle_sine(u_r)
        pk_f = P[0, i] * mu_i
        pk_r = P[1, i] * mu_i
        if capped:
            pk_f = pk_f * capacity[0, i]
            pk_r = pk_r * capacity[1, i]
        F_f = pk_f * u_f
        F_r = pk_r * u_r
        if relaxed:
            s = item(sigma, i)
            s = s if s > 0 else np.inf
            c = v * cos_b[i]
            for r in range(2):
                d = steady[r, i] - x[4 + r, i]
                d = d * c
                out[4 + r, i] = d / s
        front = F_f * item(cos_delta, i)
        if i_roll > 0:
            roll_mode_at(x, out, i, i_roll, omega, gain, zeta, front + F_r)
        psi_dot = x[1, i]
        out[0, i] = psi_dot
        F_wi = F_w[i]
        yaw = item(l_f, i) * front
        yaw = yaw - item(l_r, i) * F_r
        yaw = yaw + (item(M_w, i) if has_M_w else F_wi * item(M_c, i))
        out[1, i] = yaw * item(yaw_factor, i)
        lateral = front + F_r
        lateral = lateral + F_wi
        total[i] = lateral
        lateral = lateral * cos_b[i]
        lateral = lateral * item(inv_mv, i)
        lateral = lateral - psi_dot
        lateral = lateral + item(a_v, i)
        if has_v_dot:
            lateral = lateral - v_dot_v * sin_b[i]
        out[2, i] = lateral
        course = x[0, i] + item(k, i) * x[2, i]
        out[3, i] = course
        if not abs(course) < 3.0:
            far = True
    return far


@compiled
def _scaled_sine(t, v, out):
    """v sin(angle) into ``out`` (n,) from t = tan(angle / 2) (axle_loads.half_angle_sin_cos)."""
    for i in range(t.shape[0]):
        out[i] = v * half_angle_sine(t[i])


def course_sine_into(course, t, v: float, far: bool) -> None:
    """v sin(course) into ``course`` (n,) (rad in, m/s out), each realisation as
    :func:`uqdrive.vehicle.axle_loads.course_sine` times v, to the bit: the half-angle identity from
    ``t`` = NumPy's tan(course / 2) where |course| < 3 rad, NumPy's sine where a course turned
    further or is NaN (``far``: whether any may have; False: none)."""
    away = ~(np.abs(course) < 3.0) if far else None
    turned = None if away is None else np.sin(course[away])
    _scaled_sine(t, v, course)
    if away is not None:
        course[away] = v * turned


@compiled
def near_sine(angle, t, v) -> bool:
    """v sin(angle) into ``angle`` (n,) from t = tan(angle / 2) by the half-angle identity where
    every angle is within 3 rad of zero (:func:`uqdrive.vehicle.axle_loads.course_sine` times v, to
    the bit), and True; else (an angle at 3 rad or more, or NaN) False, ``angle`` left as it is.

    Parameters
    ----------
    angle : ndarray, shape (n,)
        The course psi + k beta (rad), overwritten by v sin of it.
    t : ndarray, shape (n,)
        NumPy's tan(angle / 2) (-).
    v : float
        Speed (m/s).
    """
    for i in range(angle.shape[0]):
        if not abs(angle[i]) < 3.0:
            return False
    _scaled_sine(t, v, angle)
    return True


class ChassisConstants:
    """The constants the compiled chassis rates read per realisation, each an array (n,) whether or
    not it varies (one compiled loop for every structure: numbers and arrays would compile one per
    combination of their kinds, ~2 s each on a cold cache), and the loads' work arrays.

    Parameters
    ----------
    n : int
        Realisations.
    lever, static : ndarray, shape (2, n)
        [l_f, -l_r] (m) and the static axle loads (N).
    mu : float or ndarray, shape (n,)
        Friction (-).
    balance : uqdrive.vehicle.dynamics.rhs.Balance
        The balances (multiplying form): l_f, l_r (m), M_c (m) and 1 / I_z (1 / (kg m^2)).
    sigma : float or ndarray, shape (n,), or None
        Relaxation length (m, 0: none) where the tyres relax.
    roll : tuple (i_roll, omega, gain, zeta) or None
        The roll steer's first state row, its frequency (rad/s), steer per newton (rad/N) and damping (-).
    course_weight : float or ndarray, shape (n,)
        k of psi + k beta (-).
    loads : dict or None
        Where the loads follow the tyres' force: the mass ``m`` (kg) and ``a_lat`` (m/s^2) of their
        steady guess and the arguments of :func:`.load_newton.newton_loads` that do not change
        between calls (``K``, ``steps``, ``L`` and the flags ``pitching``, ``transferring``,
        ``slipping``, ``sensitive``).
    """

    def __init__(self, n: int, lever, static, mu, balance, sigma, roll, course_weight, loads):
        self.n = n
        self.lever = np.ascontiguousarray(lever, float)
        self.static = np.ascontiguousarray(static, float)
        self.mu = realisations(mu, n)
        self.l_f, self.l_r, self.M_c = realisations(balance.l_f, n), realisations(balance.l_r, n), realisations(balance.M_c, n)
        self.yaw_factor = realisations(balance.yaw_factor, n)
        self.relaxed = sigma is not None
        self.sigma = realisations(0.0 if sigma is None else sigma, n)
        self.i_roll, *roll = (0, 0.0, 0.0, 0.0) if roll is None else roll
        self.omega, self.gain, self.zeta = (realisations(a, n) for a in roll)
        self.k = realisations(course_weight, n)
        self.loads = loads
        self.m, self.a_lat = (realisations(0.0 if loads is None else loads[name], n) for name in ("m", "a_lat"))
        self.trig = np.zeros((3, n))  # tan, cos and sin of beta (the loads' loop reads those its terms need)
        self.t, self.T, self.slip = np.empty(n), np.empty(n), np.empty((2, n))
        self.total = np.empty(n)  # the last call's force across the car F_f cos(delta) + F_r + F_w (N)
        self.none = np.empty((0, n))  # an absent term's rows
        self.ones = np.ones(n)  # a factor of one: the same doubles
        self.P, self.capacity, self.factors = np.empty((2, n)), np.empty((2, n)), np.empty((4, n))  # the loads' loop's outputs
        self._rows = tuple(self.trig)
        self._terms = () if loads is None else tuple(bool(loads[k]) for k in ("pitching", "transferring", "slipping", "sensitive"))

    def newton_loads(self, front, unit, F_w, v_dot: float, B_f, B_r, C, yielding: bool):
        """:func:`.load_newton.newton_loads` from ``self.T`` (the steady guess), ``self.trig`` and
        ``self.slip`` with the constants of ``loads``, into ``self.P``, ``self.capacity`` and
        ``self.factors`` (returned): no arrays made per call (~4 us a call less at 300
        realisations). Arguments as :func:`.load_newton.newton_loads`'."""
        a = self.loads
        loop = newton_loop(*self._terms, unit.shape[0] == 2, bool(yielding))
        tan_b, cos_b, sin_b = self._rows
        loop(self.T, a["K"], tan_b, cos_b, sin_b, front, self.slip, unit, F_w, self.P, self.capacity, self.factors, a["steps"], float(v_dot),
             a["L"], B_f, B_r, C)
        return self.P, self.capacity, self.factors


def chassis_arguments(rhs, x, steps: int, per_run=(), shapes: bool = False):
    """The arguments of :class:`ChassisConstants` that a chassis right-hand side ``rhs`` gives
    (``roll`` and ``loads`` built from it), or None where a compiled loop cannot read them:
    per-realisation stiffness or shape factors (unless ``shapes``: B (2, n) and C (n,) are read per
    realisation), per-axle constants (also among ``per_run``), anything but float64."""
    n = x.shape[1]
    per_run = (rhs.mu, rhs.sigma, rhs.roll_omega, rhs.roll_gain, rhs.roll_zeta, rhs.k, rhs.m, rhs.a_lat, rhs.balance.l_f, rhs.balance.l_r,
               rhs.balance.M_c, rhs.balance.yaw_factor, *per_run)
    one_shape = np.shape(rhs.B) == (2, 1) and np.ndim(rhs.C) == 0
    per_realisation = shapes and np.shape(rhs.B) == (2, n) and np.shape(rhs.C) in ((), (n,))
    if (x.dtype != np.float64 or not (one_shape or per_realisation) or rhs.lever.shape != (2, n) or np.shape(rhs.static) != (2, n)
            or any(np.ndim(a) > 1 or np.asarray(a).dtype.kind not in "iuf" for a in per_run)):
        return None
    loads = None
    if rhs.loaded:
        loads = {"m": rhs.m, "a_lat": rhs.a_lat, "K": rhs.load_constants(n), "steps": steps, "L": float(rhs.L), "pitching": rhs.pitching,
                 "transferring": rhs.transferring, "slipping": rhs.slipping, "sensitive": rhs.sensitive}
    roll = (rhs.i_roll, rhs.roll_omega, rhs.roll_gain, rhs.roll_zeta) if rhs.rolling else None
    return {"n": n, "lever": rhs.lever, "static": rhs.static, "mu": rhs.mu, "balance": rhs.balance,
            "sigma": rhs.sigma if rhs.relaxed else None, "roll": roll, "course_weight": rhs.k, "loads": loads}


class FusedChassisRates(ChassisConstants):
    """:meth:`uqdrive.vehicle.track_extended.ExtendedSingleTrackRHS.__call__` of a Magic-Formula
    chassis model (its wheels yielding to their force without relaxation nor the load-sensitive
    tyre), the same numbers: its constants and work arrays for ``n`` realisations.

    Parameters
    ----------
    E : float or ndarray, shape (n,)
        The curvature factor (-).
    B, C : ndarray, shapes (2, 1) or (2, n), and float or ndarray, shape (n,)
        The front and rear stiffness factors and the shape factor (-), one for all realisations or each its own.
    kappa : float or ndarray, shape (n,), optional
        Compliance steer (static loads, no relaxation): front wheel angle (rad) per newton of the
        front axle's force; None: the wheels do not yield.
    **constants
        Those of :class:`ChassisConstants`.
    """

    def __init__(self, E, B, C, kappa=None, **constants):
        super().__init__(**constants)
        n = self.n
        self.E, self.B_f, self.B_r, self.C = realisations(E, n), factor(B[0], n), factor(B[1], n), factor(C, n)
        self.front_peak = self.static[0] * self.mu  # the yielding front's peak on static loads (N)
        self.front_yield = None if kappa is None else FrontYield(n, self.B_f, self.C, self.E, realisations(kappa, n))
        self.half_wheel, self.cos_delta = np.empty(n), np.empty(n)
        self.q, self.steady, self.bx, self.F, self.unit = (np.empty((2, n)) for _ in range(5))
        self.sensitive = self.loads is not None and bool(self.loads["sensitive"])  # B moves with the loads: its curve per Newton step
        if self.sensitive:
            self.newton_work = (self.P, np.empty((2, n)), np.empty((2, n)), self.bx, self.capacity, self.factors, self.F)
        elif self.front_yield is not None and self.loads is not None:  # the front's yield at each step of the loads' loop
            self.newton_work = (self.P, np.empty((2, n)), np.empty((2, n)), self.capacity, self.factors, self.F, self.cos_delta)
        self.no_roll = np.empty(0)  # no roll steer's row

    def __call__(self, x, out, delta, cos_delta, F_w, M_w, v: float, v_dot: float, inv_mv, a_v, profile: bool) -> None:
        """dx/dt of ``x`` into ``out`` (n_states, n), float64, from one half step's wheel angle ``delta``
        (rad, a number or (n,)) with its cosine where it is a number (else None), side wind ``F_w``
        (n,) (N), wind moment ``M_w`` (n,) (N m; None: M_c F_w), speed ``v`` (m/s) and its rate (m/s^2),
        1 / (m v) and a_lat / v; ``profile``: the speed follows a profile (beta_dot's -(v' / v) sin beta)."""
        n, trig, t, q, bx, F = self.n, self.trig, self.t, self.q, self.bx, self.F
        if x.shape[1] != n or out.shape != x.shape:  # the compiled loops index without bounds checks
            raise ValueError(f"states of shape {x.shape} (out {out.shape}) for rates built for {n} realisations")
        beta = x[2]
        rolling, loaded = self.i_roll > 0, self.loads is not None
        eps = x[self.i_roll] if rolling else self.no_roll
        wheel = cos_delta is None or rolling
        delta = float(delta) if np.ndim(delta) == 0 else delta
        F_w = realisations(F_w, n)
        np.multiply(beta, 0.5, t)
        np.tan(t, t)
        _side_slip(t, trig[2], trig[1], self.lever, x[1], v, q, loaded, self.T, self.m, v_dot, self.a_lat, F_w, wheel, delta, eps,
                   self.half_wheel)
        np.arctan(q, q)
        if wheel:
            np.tan(self.half_wheel, self.half_wheel)
        _slip_angles(q, delta, eps, x[4:6] if self.relaxed else self.none, self.sigma, self.B_f, self.B_r, self.steady, self.slip, bx,
                     wheel, self.half_wheel, self.cos_delta)
        cos_delta = self.cos_delta if wheel else float(cos_delta)
        P, mu, capacity, unit = self.static, self.mu, self.none, bx
        if self.sensitive:  # the peaks mu P c f_D and the curve's tangents at B f_K / f_D of the loads the loop ends at
            a = self.loads
            np.tan(beta, trig[0])
            sensitive_newton(self.T, a["K"], trig, realisations(cos_delta, n), self.slip, F_w, a["steps"], v_dot, a["L"], self.B_f, self.B_r,
                             self.C, self.E, self.newton_work, pitching=a["pitching"], transferring=a["transferring"], slipping=a["slipping"])
            P, mu = self.newton_work[2], self.ones  # the peak times one: the same doubles
            loaded = False
        else:
            curve_tangent(bx, self.E, self.C, F)
        if loaded:
            unit, a = self.unit, self.loads
            _unit_forces(bx, unit)
            if a["pitching"] or a["slipping"]:
                np.tan(beta, trig[0])
            if self.front_yield is not None:  # the front's yield on the loads of each Newton step
                yielding_newton(self.T, a["K"], trig, self.steady[0], realisations(delta - eps if rolling else delta, n), unit, F_w,
                                a["steps"], v_dot, a["L"], self.B_f, self.C, self.front_yield, self.newton_work, pitching=a["pitching"],
                                transferring=a["transferring"], slipping=a["slipping"])
                P, capacity, cos_delta = self.P, self.capacity, self.cos_delta
            else:
                P, capacity, _ = self.newton_loads(realisations(cos_delta, n), unit, F_w, v_dot, self.B_f, self.B_r, self.C, False)
            capacity = capacity if a["slipping"] else self.none
        from_tangent = not loaded
        if self.front_yield is not None and not loaded:  # static loads, no relaxation: the front wheels yield to their force
            unit, from_tangent = self.unit, False
            _unit_forces(bx, unit)
            wheel = realisations(delta - eps if rolling else delta, n)  # the wheel angle less the roll steer
            self.front_yield(self.steady[0], self.front_peak, wheel, unit[0], self.cos_delta)
            cos_delta = self.cos_delta
        far = _rates(unit, from_tangent, P, mu, capacity, cos_delta, x, out, self.steady if self.relaxed else self.none, self.sigma, v,
                     trig[1], trig[2], self.i_roll, self.omega, self.gain, self.zeta, self.l_f, self.l_r, F_w, self.M_c,
                     0.0 if M_w is None else realisations(M_w, n), M_w is not None, self.yaw_factor, inv_mv, a_v,
                     v_dot / v, profile, self.k, self.total)
        np.multiply(out[3], 0.5, t)
        np.tan(t, t)
        course_sine_into(out[3], t, v, far)


def fused_chassis_rates(rhs, x, steps: int, compiled_loop: bool):
    """:class:`FusedChassisRates` of the chassis right-hand side ``rhs``
    (:class:`uqdrive.vehicle.track_extended.ExtendedSingleTrackRHS`) for states ``x``
    (n_states, n), or None where it does not serve: the linear tyre
    (:func:`.fused_linear.fused_linear_chassis_rates`), compliance steer beside relaxation or the
    load-sensitive tyre, a loads' loop not compiled (``compiled_loop``), constants
    :func:`chassis_arguments` refuses."""
    if (not rhs.saturating or (rhs.loaded and not compiled_loop)
            or (rhs.compliant and (rhs.relaxed or (rhs.loaded and rhs.sensitive)))):
        return None
    constants = chassis_arguments(rhs, x, steps, (rhs.E, rhs.kappa), shapes=True)
    if constants is None:
        return None
    return FusedChassisRates(rhs.E, rhs.B, rhs.C, rhs.kappa if rhs.compliant else None, **constants)

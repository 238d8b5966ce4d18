"""The right-hand side of the single-track model with chassis effects in JAX (float64), the
equations of :class:`uqdrive.vehicle.track_extended.ExtendedSingleTrackRHS` for n realisations.

The equations are the NumPy path's term for term (load transfer and the loads-forces Newton loop,
combined slip, the load-sensitive tyre, compliance steer, roll steer, tyre relaxation, the speed
profile, the Magic-Formula or linear tyre), from the constants the NumPy right-hand side computed
(:func:`chassis_constants`); the two paths differ by the last bits of the transcendental
functions and of the operations a compiler reorders, nothing else. With no chassis term on it is
the NLST (5.3), which serves the Magic-Formula structures too. Which terms are on (:data:`FLAGS`)
is a static choice: the terms that are off are absent from a program. The RK4 passes:
:mod:`uqdrive.vehicle.accelerated.chassis_ensemble`.
"""

from __future__ import annotations

import numpy as np

__all__ = ["FLAGS", "chassis_constants", "chassis_rates", "chassis_lateral_acceleration"]

#: The terms a right-hand side has on (static choices of the compiled program): the Magic-Formula
#: tyre, the exact course sine, relaxation, roll steer, loads that move (and of them the
#: longitudinal, the lateral transfer, combined slip, the load-sensitive tyre), compliance steer,
#: a speed profile, the gusts' yaw moment.
FLAGS = ("saturating", "course_sine", "relaxed", "rolling", "loaded", "pitching", "transferring", "slipping", "sensitive", "compliant",
         "profile", "yaw_gust")


def chassis_constants(rhs, n: int | None = None) -> tuple[dict, dict]:
    """The per-realisation constants (arrays (n,) or (2, n), float64) and the flags of a NumPy
    chassis right-hand side ``rhs`` (:class:`~uqdrive.vehicle.track_extended.ExtendedSingleTrackRHS`),
    whose attributes hold them as the NumPy path computed them (the same doubles on both paths).

    Returns
    -------
    constants : dict of str to ndarray
        Shapes (n,) for the scalars of a realisation, (2, n) for the front and rear axle's.
    flags : dict of str to bool or int
        :data:`FLAGS`, plus ``newton_steps``, the loads' Newton steps.
    """
    from ..track_extended import LOAD_NEWTON_STEPS  # read at each call, as the NumPy right-hand side reads it

    n = int(np.size(rhs.F_w_half[0]) if n is None else n)
    one = lambda a: np.broadcast_to(np.asarray(a, float), (n,)).copy()  # noqa: E731
    two = lambda a: np.broadcast_to(np.asarray(a, float), (2, n)).copy()  # noqa: E731
    b = rhs.balance
    sigma = np.asarray(rhs.sigma, float)
    c = {"lever": two(rhs.lever), "l_f": one(b.l_f), "l_r": one(b.l_r), "M_c": one(b.M_c), "yaw_factor": one(b.yaw_factor),
         "m": one(rhs.m), "L": one(rhs.L), "static": two(rhs.static), "mu": one(rhs.mu), "B": two(rhs.B), "C": one(rhs.C), "E": one(rhs.E),
         "h_x": one(rhs.h_x), "p_Dz": one(rhs.p_Dz), "arm": two(rhs.lateral_arm), "kappa": one(rhs.kappa),
         "inv_sigma": one(np.where(sigma > 0, 1.0 / np.where(sigma > 0, sigma, 1.0), 0.0)), "roll_gain": one(rhs.roll_gain),
         "roll_omega": one(rhs.roll_omega), "roll_zeta": one(rhs.roll_zeta), "kappa_x": one(rhs.kappa_x), "drive": two(rhs.drive_share),
         "brake": two(rhs.brake_share), "q_K": one(rhs.q_K[0]), "p_D": one(rhs.p_D[0]), "h_s": one(rhs.h_s), "reference": two(rhs.reference),
         "k": one(rhs.k), "a_lat": one(rhs.a_lat), "M_w": one(0.0 if rhs.M_w is None else rhs.M_w)}
    flags = {"saturating": rhs.saturating, "course_sine": rhs.course_sine, "relaxed": rhs.relaxed, "rolling": rhs.rolling,
             "loaded": rhs.loaded, "pitching": rhs.pitching, "transferring": rhs.transferring, "slipping": rhs.slipping,
             "sensitive": rhs.sensitive, "compliant": rhs.compliant, "profile": rhs.speed_half is not None, "yaw_gust": rhs.M_w is None,
             "newton_steps": int(LOAD_NEWTON_STEPS)}
    return c, {k: (int(v) if k == "newton_steps" else bool(v)) for k, v in flags.items()}


def _curve(jnp, peak, q, B, c, saturating):
    """Force (N) at slip ``q`` (rad): peak sin(C atan(u)), u = B q - E (B q - atan(B q)) (the
    Magic Formula (2.2a)), or the linear tyre's peak B C q."""
    if saturating:
        bx = B * q
        return peak * jnp.sin(c["C"] * jnp.arctan(bx - c["E"] * (bx - jnp.arctan(bx))))
    return peak * B * c["C"] * q


def _yielded_front_slip(jnp, q0, peak, B, c, saturating):
    """:func:`uqdrive.vehicle.axle_loads.yielded_front_slip`: the front slip q = q0 - kappa F(q),
    exact on the linear tyre, three Newton steps on the Magic Formula."""
    C, E, kappa = c["C"], c["E"], c["kappa"]
    q = q0 / jnp.maximum(1.0 + kappa * (peak * B * C), 0.05)
    if not saturating:
        return q
    for _ in range(3):
        bx = B * q
        u = bx - E * (bx - jnp.arctan(bx))
        angle = C * jnp.arctan(u)
        slope = peak * jnp.cos(angle) * C / (1.0 + u * u) * B * (1.0 - E + E / (1.0 + bx * bx))
        q = q - (q - q0 + kappa * (peak * jnp.sin(angle))) / jnp.maximum(1.0 + kappa * slope, 0.05)
    return q


def _body_ax(c, tyres, trig, v_dot, F_w):
    """The body's a_x = v' cos(beta) - tan(beta) (a_y - v' sin(beta)), a_y = (tyres + F_w) / m + a_lat."""
    tan_b, cos_b, sin_b = trig
    return v_dot * cos_b - tan_b * ((tyres + F_w) / c["m"] + c["a_lat"] - v_dot * sin_b)


def _loads(jnp, c, f, tyres, trig, v_dot, F_w):
    """Effective axle loads P (2, n) (N) and dP / d tyres (2, n) while the tyres carry ``tyres``
    (:meth:`uqdrive.vehicle.axle_loads.AxleLoads.axle_loads`): the longitudinal transfer m a_x h_x / L, the
    lateral chi_i h tyres / t per wheel with the load-sensitive peak (1 + p_Dz dfz), no wheel pulling the road."""
    static, zero = c["static"], jnp.zeros_like(c["static"])
    if f["pitching"]:
        shift = c["m"] * _body_ax(c, tyres, trig, v_dot, F_w) * c["h_x"] / c["L"]
        raw = static + jnp.stack([-shift, shift])
        F_z = jnp.maximum(raw, 0.0)
        d_shift = -trig[0] * c["h_x"] / c["L"]
        d_raw = jnp.where(raw > 0, jnp.stack([-d_shift, d_shift]), zero)
    else:
        raw = F_z = static
        d_raw = zero
    if not f["transferring"]:
        return F_z, d_raw
    dF = c["arm"] * tyres
    F0 = 0.5 * static
    P, dP = zero, zero
    for sign in (-1.0, 1.0):
        w = jnp.maximum(0.5 * F_z + sign * dF, 0.0)
        gain = 1.0 + c["p_Dz"] * (w - F0) / F0
        P = P + w * jnp.maximum(gain, 0.0)
        d_w = 0.5 * d_raw + sign * c["arm"]
        dP = dP + jnp.where((w > 0) & (gain > 0), (gain + c["p_Dz"] * w / F0) * d_w, zero)
    return P, dP


def _capacity(jnp, c, f, tyres, trig, v_dot, F_w, P):
    """Share (2, n) of each axle's lateral force the longitudinal force F_x = m a_x leaves (the friction ellipse)."""
    if not f["slipping"]:
        return 1.0
    F_x = c["m"] * _body_ax(c, tyres, trig, v_dot, F_w)
    used = c["kappa_x"] * jnp.where(F_x > 0, c["drive"], c["brake"]) * F_x / jnp.maximum(c["mu"] * P, 1e-3 * c["static"])
    return jnp.sqrt(jnp.maximum(1.0 - used * used, 0.0))


def _factors(jnp, c, f, tyres, trig, v_dot, F_w):
    """The load-sensitive tyre's peak and stiffness factors (2, n) each, 1 + p_D dfz and 1 + q_K dfz (>= 0.05), or None."""
    if not f["sensitive"]:
        return None
    shift = c["m"] * _body_ax(c, tyres, trig, v_dot, F_w) * c["h_s"] / c["L"]
    dfz = (c["static"] + jnp.stack([-shift, shift]) - c["reference"]) / c["reference"]
    return jnp.maximum(1.0 + c["p_D"] * dfz, 0.05), jnp.maximum(1.0 + c["q_K"] * dfz, 0.05)


def _at_loads(jnp, c, f, P, q, delta, lagged, capacity=1.0, factors=None):
    """Slip angles (2, n), front wheel angle (n,) and axle forces (2, n) on the effective loads
    ``P`` (:meth:`~uqdrive.vehicle.track_extended.ExtendedSingleTrackRHS._at_loads`)."""
    peak, B = P * c["mu"] * capacity, c["B"]
    if factors is not None:
        peak, B = peak * factors[0], B * (factors[1] / factors[0])
    if lagged is not None:
        F = _curve(jnp, peak, lagged, B, c, f["saturating"])
        if f["compliant"]:
            q = q.at[0].add(-(c["kappa"] * F[0]))
            delta = delta - c["kappa"] * F[0]
        return q, delta, F
    if f["compliant"]:
        q_front = _yielded_front_slip(jnp, q[0], peak[0], B[0], c, f["saturating"])
        delta = delta - (q[0] - q_front)
        q = q.at[0].set(q_front)
    return q, delta, _curve(jnp, peak, q, B, c, f["saturating"])


def _forces(jnp, c, f, x, delta, F_w, v, v_dot, trig):
    """Slip angles, front wheel angle and axle forces at the states ``x`` (the loads' Newton loop
    of :meth:`~uqdrive.vehicle.track_extended.ExtendedSingleTrackRHS._forces` where loads move)."""
    psi_dot, beta = x[1], x[2]
    tan_b, cos_b, sin_b = trig
    lever = c["lever"]
    if f["saturating"]:
        q = -jnp.arctan((lever * psi_dot + sin_b * v) / (cos_b * v))
    else:
        q = -(beta + lever * psi_dot / v)
    q = q.at[0].add(delta)
    if f["rolling"]:
        q = q.at[0].add(-x[-2])
        delta = delta - x[-2]
    lagged = jnp.where(c["inv_sigma"] > 0, jnp.stack([x[4], x[5]]), q) if f["relaxed"] else None
    if not f["loaded"]:
        return _at_loads(jnp, c, f, c["static"], q, delta, lagged)
    T = c["m"] * (v * psi_dot * cos_b + v_dot * sin_b - c["a_lat"]) - F_w
    floor = 1e-3 * c["static"]
    for _ in range(f["newton_steps"]):
        P, dP = _loads(jnp, c, f, T, trig, v_dot, F_w)
        _, d, F = _at_loads(jnp, c, f, P, q, delta, lagged, _capacity(jnp, c, f, T, trig, v_dot, F_w, P),
                            _factors(jnp, c, f, T, trig, v_dot, F_w))
        dF = F / jnp.maximum(P, floor)
        if f["compliant"] and lagged is None:
            dF = dF.at[0].divide(1.0 + c["kappa"] * P[0] * c["mu"] * c["B"][0] * c["C"])
        front = jnp.cos(d) if f["saturating"] else 1.0
        gain = front * dF[0] * dP[0] + dF[1] * dP[1]
        T = T + (front * F[0] + F[1] - T) / jnp.maximum(1.0 - gain, 0.05)
    P, _ = _loads(jnp, c, f, T, trig, v_dot, F_w)
    return _at_loads(jnp, c, f, P, q, delta, lagged, _capacity(jnp, c, f, T, trig, v_dot, F_w, P), _factors(jnp, c, f, T, trig, v_dot, F_w))


def _axle_forces(jnp, c, f, x, delta, F_w, v, v_dot):
    """Slip angles (2, n), axle forces (2, n) and the front's force across the car (F_f cos delta
    on the Magic Formula, F_f on the linear tyre) at the states ``x``, with sin and cos of beta."""
    sin_b, cos_b = jnp.sin(x[2]), jnp.cos(x[2])
    q, delta, F = _forces(jnp, c, f, x, delta, F_w, v, v_dot, (sin_b / cos_b, cos_b, sin_b))
    return q, F, (F[0] * jnp.cos(delta) if f["saturating"] else F[0]), sin_b, cos_b


def chassis_lateral_acceleration(c, f, x, delta, F_w, v, v_dot):
    """a_y (m/s^2), shape (n,): (F_f cos delta + F_r + F_w) / m at the states ``x``, what an
    accelerometer at the centre of gravity reads (:meth:`~uqdrive.vehicle.track_extended.ExtendedSingleTrackRHS.lateral_acceleration`);
    arguments as :func:`chassis_rates`."""
    import jax.numpy as jnp

    _, F, fc, _, _ = _axle_forces(jnp, c, f, x, delta, F_w, v, v_dot)
    return (fc + F[1] + F_w) / c["m"]


def chassis_rates(c, f, x, delta, F_w, v, v_dot):
    """dx/dt of the single-track model with chassis effects, :meth:`~uqdrive.vehicle.track_extended.ExtendedSingleTrackRHS.__call__`.

    Parameters
    ----------
    c, f : dict
        Constants and flags of :func:`chassis_constants`.
    x : sequence of d jax arrays, shape (n,) each (or one array (d, n))
        psi, psi_dot, beta, y (rad, rad/s, rad, m), then the lagged slip angles (rad) where the
        tyres relax and the roll steer angle (rad) and its rate (rad/s) where the body rolls.
    delta : jax array, shape (n,) or (1,)
        Front wheel angle (rad).
    F_w : jax array, shape (n,)
        Side wind (N).
    v, v_dot : float or jax array, shape (n,)
        Speed (m/s) and its rate (m/s^2).

    Returns
    -------
    tuple of d jax arrays, shape (n,) each
        dx/dt row by row (the RK4 carries the rows apart: stacking them at every stage splits a
        step into more GPU kernels, :func:`uqdrive.vehicle.accelerated.nlst_program`'s finding).
    """
    import jax.numpy as jnp

    psi, psi_dot, beta = x[0], x[1], x[2]
    q, F, fc, sin_b, cos_b = _axle_forces(jnp, c, f, x, delta, F_w, v, v_dot)
    sat = f["saturating"]
    M_w = F_w * c["M_c"] if f["yaw_gust"] else c["M_w"]
    yaw = (c["l_f"] * fc - c["l_r"] * F[1] + M_w) * c["yaw_factor"]
    slip = (fc + F[1] + F_w) * (cos_b if sat else 1.0) * (1.0 / (c["m"] * v)) - psi_dot + c["a_lat"] / v
    if f["profile"]:
        slip = slip - v_dot / v * (sin_b if sat else beta)
    course = psi + c["k"] * beta
    rows = [psi_dot, yaw, slip, v * (jnp.sin(course) if f["course_sine"] else course)]
    if f["relaxed"]:
        rows += list((q - jnp.stack([x[4], x[5]])) * (v * (cos_b if sat else 1.0)) * c["inv_sigma"])
    if f["rolling"]:
        w, eps, rate = c["roll_omega"], x[-2], x[-1]
        rows += [rate, w * w * (c["roll_gain"] * (fc + F[1]) - eps) - 2.0 * c["roll_zeta"] * w * rate]
    return tuple(rows)

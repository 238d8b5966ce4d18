"""The axle loads of the chassis right-hand side (:class:`uqdrive.vehicle.track_extended.ExtendedSingleTrackRHS`):
load transfer, the friction ellipse's share and the load-sensitive tyre's factors, the trigonometry they
share, and the front wheels' yield to the force those loads carry (compliance steer).
"""

from __future__ import annotations

import numpy as np

from .single_track import curvature_argument

__all__ = ["AxleLoads", "SideSlip", "course_sine", "half_angle_sin_cos", "half_angle_sin_cos_into", "opposite", "yielded_front_slip"]


def half_angle_sin_cos_into(angle, sin_out, cos_out, t, inv) -> None:
    """sin and cos of ``angle`` (rad, |angle| < pi) from t = tan(angle / 2), sin = 2 t / (1 + t^2),
    cos = (1 - t^2) / (1 + t^2), into ``sin_out`` and ``cos_out`` (None: the sine only), in place.

    NumPy vectorises its tangent but not its float64 sine and cosine (7 ns an element each, the
    tangent's pair a third of that): within 2 ulp of them. ``t`` and ``inv`` are work arrays of
    ``angle``'s shape; ``sin_out`` may be ``angle`` itself.
    """
    np.multiply(angle, 0.5, t)
    np.tan(t, t)
    np.multiply(t, t, inv)
    if cos_out is not None:
        np.subtract(1.0, inv, cos_out)
    np.add(inv, 1.0, inv)
    np.divide(1.0, inv, inv)
    if cos_out is not None:
        cos_out *= inv
    np.multiply(t, 2.0, sin_out)
    sin_out *= inv


def half_angle_sin_cos(angle):
    """sin and cos of ``angle`` (any shape) (rad, |angle| < pi), new arrays: the numbers of
    :func:`half_angle_sin_cos_into` to the bit, written as one expression each (at the chassis
    right-hand side's 300 realisations its temporaries cost less than the in-place form's views).

    NumPy vectorises its tangent but not its float64 sine and cosine (here 14 ns an element
    against 2 ns): the pair costs a third of np.sin alone, within 2 ulp of it (|angle| < pi, the
    side slip, wheel and Magic-Formula angles of a car that has not spun)."""
    t = np.tan(0.5 * angle)
    t2 = t * t
    inv = 1.0 / (1.0 + t2)
    return 2.0 * t * inv, (1.0 - t2) * inv


def course_sine(angle):
    """sin(angle) (n,): by :func:`half_angle_sin_cos` where the angle is within 3 rad of zero, by
    NumPy's sine where a course has turned further (or is NaN): each realisation by its own angle,
    so that a realisation's numbers do not depend on the others simulated with it."""
    near = np.abs(angle) < 3.0
    if near.all():
        return half_angle_sin_cos(angle)[0]
    out = np.sin(angle)
    out[near] = half_angle_sin_cos(angle[near])[0]
    return out


def yielded_front_slip(q0, peak, B, C, E, kappa, saturating: bool):
    """Front slip with the wheels yielding to their own force: q = q0 - kappa F(q).

    Linear tyre: q0 / max(1 + kappa c, 0.05), c = peak B C; Magic Formula (Pacejka (2.2a), its
    force peak sin(C atan(u)), u = B q - E (B q - atan(B q))): three Newton steps from it (the
    loop's gain kappa dF/dq is below 1 in the fitted range, so the residual falls quadratically to
    round-off).

    Parameters
    ----------
    q0 : ndarray, shape (n,)
        The front's slip angle the wheel angle alone makes (rad).
    peak : ndarray, shape (n,)
        The front axle's peak force (N).
    B, C : float or ndarray, shape (1,)
        The front's stiffness and the shape factor (-).
    E : float or ndarray, shape (n,)
        The curvature factor (-).
    kappa : float or ndarray, shape (n,)
        Front wheel angle (rad) per newton of the front axle's force.
    saturating : bool
        The Magic Formula, else the linear tyre.

    Returns
    -------
    ndarray, shape (n,)
        The yielded slip angle (rad).
    """
    stiff = peak * B * C
    q = q0 / np.maximum(1.0 + kappa * stiff, 0.05)
    if not saturating:
        return q
    for _ in range(3):
        bx = B * q
        u = curvature_argument(bx, E)
        angle = C * np.arctan(u)  # the force's and its slope's: D sin(angle), D cos(angle) C u' / (1 + u^2)
        sin_a, cos_a = half_angle_sin_cos(angle)
        slope = peak * cos_a * C / (1.0 + u * u) * B * (1.0 - E + E / (1.0 + bx * bx))
        q = q - (q - q0 + kappa * (peak * sin_a)) / np.maximum(1.0 + kappa * slope, 0.05)
    return q


class SideSlip:
    """The side-slip angle beta (n,) (rad) with its sine, cosine and tangent, each computed at most
    once per state (sin and cos cost NumPy ten times an arctan: several terms need them)."""

    __slots__ = ("beta", "_sin", "_cos", "_tan")

    def __init__(self, beta):
        self.beta, self._sin, self._cos, self._tan = beta, None, None, None

    @classmethod
    def of(cls, beta) -> "SideSlip":
        """``beta`` itself when it is one already."""
        return beta if isinstance(beta, cls) else cls(beta)

    @property
    def sin(self):
        """sin(beta) (n,) (-), by :func:`half_angle_sin_cos` with the cosine."""
        if self._sin is None:
            self._sin, self._cos = half_angle_sin_cos(self.beta)
        return self._sin

    @property
    def cos(self):
        """cos(beta) (n,) (-), by :func:`half_angle_sin_cos` with the sine."""
        if self._cos is None:
            self._sin, self._cos = half_angle_sin_cos(self.beta)
        return self._cos

    @property
    def tan(self):
        """tan(beta) (n,) (-)."""
        if self._tan is None:
            self._tan = np.tan(self.beta)
        return self._tan


def opposite(shift):
    """[-shift, shift] (2, n) of a load ``shift`` (n,) (N) moved from the front axle to the rear."""
    out = np.empty((2,) + np.shape(shift))
    np.negative(shift, out[0])
    out[1] = shift
    return out


class AxleLoads:
    """The loads' part of :class:`uqdrive.vehicle.track_extended.ExtendedSingleTrackRHS` (its
    attributes set there): the effective axle loads while the tyres carry a lateral force, the
    lateral share the longitudinal force leaves, the load-sensitive tyre's factors."""

    def _full(self, value: float, like):
        """A constant array of ``like``'s shape (never written): NumPy's maximum and where take their
        vectorised loop only for operands of the full shape (a scalar one costs ten times the
        arithmetic at a few thousand realisations); the same numbers as the scalar."""
        key = (value, like.shape)
        a = self._filled.get(key)
        if a is None:
            a = self._filled[key] = np.full(like.shape, value)
        return a

    def _at_least(self, x, value: float):
        """np.maximum(x, value) by :meth:`_full`."""
        return np.maximum(x, self._full(value, x))

    def axle_loads(self, tyres, beta, v_dot=0.0, F_w=0.0, slope=False):
        """Effective axle loads P (2, n) (N) while the tyres carry the lateral force ``tyres`` (n,) (N).

        The roll moment of the tyres' forces about the centre of gravity moves chi_i h tyres / t to
        each axle's outer wheel; the body's acceleration along x, a_x = v' cos(beta) - tan(beta)
        (a_y - v' sin(beta)) with a_y = (tyres + F_w) / m + a_lat, moves m a_x h_x / L from the
        front to the rear axle (the drive or brake force that holds the speed or follows ``v_dot``).
        With ``slope``, also dP / d tyres (2, n), for the loop in :meth:`_forces`.
        """
        return self._loads(tyres, self._trig(beta), v_dot, F_w, slope)

    def _trig(self, beta):
        """tan, cos and sin of beta where the longitudinal transfer needs them (None without it)."""
        if not self.pitching:
            return None
        b = SideSlip.of(beta)
        return b.tan, b.cos, b.sin

    def _loads(self, tyres, trig, v_dot, F_w, slope):
        """:meth:`axle_loads` with beta's ``trig`` (:meth:`_trig`) computed once per state.

        Without a longitudinal transfer the axles keep their static loads; without a lateral one
        each axle's two wheels carry half its load at its peak per unit load (P = F_z, dP its
        shift's slope): the same numbers as the general per-wheel sum, without its work."""
        if trig is None:
            raw = F_z = self.static
            d_shift = 0.0
        else:
            tan_b, cos_b, sin_b = trig
            a_y = (tyres + F_w) / self.m + self.a_lat
            if np.ndim(v_dot) == 0 and v_dot == 0.0:  # held speed: the same numbers, fewer operations
                a_x = -(tan_b * a_y)
            else:
                a_x = v_dot * cos_b - tan_b * (a_y - v_dot * sin_b)
            shift = self.m * a_x * self.h_x / self.L
            raw = self.static + opposite(shift)
            F_z = self._at_least(raw, 0.0)  # an axle cannot pull the road
            d_shift = -tan_b * self.h_x / self.L if slope else 0.0  # d shift / d tyres
        if not self.transferring:
            if not slope:
                return F_z
            if trig is None:
                return F_z, 0.0
            return F_z, np.where(raw > 0, np.stack(np.broadcast_arrays(-d_shift, d_shift)), self._full(0.0, raw))
        dF = self.lateral_arm * tyres
        F0 = 0.5 * self.static
        P, dP = 0.0, 0.0
        if slope:  # d (F_z / 2) / d tyres
            d_half_load = np.where(raw > 0, 0.5 * np.stack(np.broadcast_arrays(-d_shift, d_shift)), self._full(0.0, raw)) if trig is not None else 0.0
        # per wheel (inner, outer), a lifted wheel carrying nothing and no wheel's peak below zero
        for sign in (-1.0, 1.0):
            w = self._at_least(0.5 * F_z + sign * dF, 0.0)
            gain = 1.0 + self.p_Dz * (w - F0) / F0
            P = P + w * self._at_least(gain, 0.0)
            if slope:
                d_w = d_half_load + sign * self.lateral_arm
                dP = dP + np.where((w > 0) & (gain > 0), (gain + self.p_Dz * w / F0) * d_w, self._full(0.0, w))
        return (P, dP) if slope else P

    def load_constants(self, n: int):
        """The per-realisation constants of the compiled loads' loop, rows :data:`uqdrive.vehicle.dynamics.load_newton.ROWS`
        (len(ROWS), n), stacked at the first call and kept (the chassis right-hand side's constants do not change)."""
        if self._constants is None:
            from .dynamics.jit import realisations
            from .dynamics.load_newton import ROWS  # numba: only where a chassis model transfers load

            arm, drive, brake = self.lateral_arm, self.drive_share, self.brake_share
            rows = {"m": self.m, "a_lat": self.a_lat, "h_x": self.h_x, "static_f": self.static[0], "static_r": self.static[1], "arm_f": arm[0],
                    "arm_r": arm[1], "p_Dz": self.p_Dz, "mu": self.mu, "kappa": self.kappa, "kappa_x": self.kappa_x, "drive_f": drive[0],
                    "drive_r": drive[1], "brake_f": brake[0], "brake_r": brake[1], "p_D": self.p_D[0], "q_K": self.q_K[0], "h_s": self.h_s,
                    "reference_f": self.reference[0], "reference_r": self.reference[1]}
            self._constants = np.stack([realisations(rows[name], n) for name in ROWS])
        return self._constants

    def lateral_capacity(self, tyres, beta, v_dot, F_w, P):
        """Share (2, n) of each axle's lateral force the longitudinal force leaves (1 without
        combined slip): sqrt(max(1 - (kappa F_x,i / (mu P_i))^2, 0)), F_x = m a_x (N) with the body's
        a_x of :meth:`axle_loads` while the tyres carry ``tyres`` (n,) (N), on the loads ``P`` (2, n)."""
        if not self.slipping:
            return 1.0
        a_y = (tyres + F_w) / self.m + self.a_lat
        b = SideSlip.of(beta)
        F_x = self.m * (v_dot * b.cos - b.tan * (a_y - v_dot * b.sin))
        used = self.kappa_x * np.where(F_x > 0, self.drive_share, self.brake_share) * F_x / np.maximum(self.mu * P, 1e-3 * self.static)
        return np.sqrt(self._at_least(1.0 - used * used, 0.0))

    def load_factors(self, tyres, beta, v_dot, F_w):
        """Peak and stiffness factors (2, n) each, 1 + p_Dz dfz and 1 + q dfz, while the tyres carry ``tyres`` (n,) (N)."""
        if not self.sensitive:
            return None
        b = SideSlip.of(beta)
        a_x = v_dot * b.cos - b.tan * ((tyres + F_w) / self.m + self.a_lat - v_dot * b.sin)
        shift = self.m * a_x * self.h_s / self.L
        dfz = (self.static + opposite(shift) - self.reference) / self.reference
        return self._at_least(1.0 + self.p_D * dfz, 0.05), self._at_least(1.0 + self.q_K * dfz, 0.05)

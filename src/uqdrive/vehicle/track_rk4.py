"""Batched RK4 of the single-track model (5.3) with a Magic-Formula (or linear) tyre, for the
augmented simulator (:class:`uqdrive.vehicle.augmented.AugmentedSimulator`).

Every realisation is integrated by the same fixed-step RK4; a step is a few dozen NumPy calls on
arrays of the batch size. The right-hand side writes into preallocated arrays (positional
``out``: NumPy parses an ``out=`` keyword in ~0.3 us more per call), so a step allocates
nothing; at the 300 realisations of a discover fit the per-call cost is most of a step.

The arithmetic is the original right-hand side's, operation by operation (same operands, same
order: only the commutative order of a few products and sums is swapped), so a realisation's
trajectory is the same to the last bit. That matters beyond tidiness: the emcee posterior of a
named tyre effect is built on these simulations, and a chain diverges on any change of the last
bits (tried: computing sin and cos from the half-angle tangent, vectorised in NumPy where sin and
cos are not, halved the cost of a step at 2400 realisations; the fits moved by 1e-10, but the
posterior of the thesis case moved by Monte-Carlo noise and its surrogate validation, 0.45 of the
0.5 allowed, failed).
"""

from __future__ import annotations

import numpy as np

from ..numerics.integrate import rk4_fixed_step_into
from .effects import ModelStructure
from .single_track import VehicleParameters

__all__ = ["SingleTrackRHS", "integrate_single_track"]


class SingleTrackRHS:
    """Right-hand side of the single-track model (5.3) with the structure's tyre law, course
    kinematics and lateral acceleration, for n realisations; writes dx/dt into a given array.

    Parameters
    ----------
    p : VehicleParameters
        Per-realisation parameters (mu, l_f, m_load arrays of shape (n,) or scalars).
    s : ModelStructure
        ``tyre``, ``course_weight`` and ``lateral_acceleration`` (scalars or arrays (n,), as
        :meth:`AugmentedSimulator.simulate_many` batches them).
    E : float or ndarray, shape (n,)
        Magic-Formula curvature factor (-).
    delta_half : ndarray, shape (J,)
        Actual steering angle (rad) on the half-step grid j h / 2.
    F_w_half : ndarray, shape (J, n)
        Lateral wind force (N) per half step and realisation (mean wind plus gust).
    yaw_gust : bool
        The gusts exert the yaw moment M_c F_w too (else M_c times the mean wind only).
    wind : ndarray, shape (n,)
        Mean wind (N).
    speed_half : tuple of two ndarrays, shape (J,), optional
        Speed v (m/s) and its rate v_dot (m/s^2) per half step (a speed profile): the speed
        change acts along the velocity, so beta_dot gains -(v_dot / v) sin beta; None: ``p.v_c``.
    """

    def __init__(self, p: VehicleParameters, s: ModelStructure, E, delta_half, F_w_half, yaw_gust: bool, wind, speed_half=None):
        n = F_w_half.shape[1]
        v = float(p.v_c)
        self.v = v
        self.l_f = np.asarray(p.l_f, float)
        self.l_r = p.l_r
        self.lever = np.stack(np.broadcast_arrays(self.l_f, -self.l_r))
        self.saturating = s.tyre == "magic_formula"
        self.Bs = np.array([[p.c_Sf], [p.c_Sr]])
        self.peak = np.stack(np.broadcast_arrays(p.F_fz * p.mu, p.F_rz * p.mu))
        self.linear = np.stack(np.broadcast_arrays(p.c_f, p.c_r))
        self.inv_I_z, self.inv_mv = 1.0 / p.I_z, 1.0 / (p.m * v)
        self.C, self.E, self.k = p.C, E, s.course_weight
        self.a_v = s.lateral_acceleration / v
        self.delta_half = np.asarray(delta_half, float)
        self.cos_delta = np.cos(self.delta_half)
        self.F_w_half = F_w_half
        self.M_c = p.M_c
        self.M_w = None if yaw_gust else p.M_c * np.asarray(wind, float)
        self._sin_b, self._cos_b, self._t, self._fc, self._tmp = (np.empty(n) for _ in range(5))
        self._q, self._bx, self._F = np.empty((2, n)), np.empty((2, n)), np.empty((2, n))
        self.speed_half = None
        if speed_half is not None:
            self.speed_half = tuple(np.asarray(a, float) for a in speed_half)
            self.inv_m, self.a_lat = 1.0 / p.m, s.lateral_acceleration

    def _at(self, j: int):
        """Speed, 1 / (m v) and a_lat / v at half step ``j`` (the constants without a profile)."""
        if self.speed_half is None:
            return self.v, self.inv_mv, self.a_v
        v = float(self.speed_half[0][j])
        return v, self.inv_m / v, self.a_lat / v

    def lateral_acceleration(self, x, j: int):
        """a_y (m/s^2), shape (n,), of ``x`` (4, n) at half step ``j``: the lateral forces over
        the mass, (F_f cos delta + F_r + F_w) / m, recovered from beta_dot of the right-hand side."""
        out = np.empty_like(x)
        self(x, j, out)
        v, _, a_v = self._at(j)
        slip_rate = 0.0 if self.speed_half is None else self.speed_half[1][j] / v * np.sin(x[2])
        return (out[2] + x[1] - a_v + slip_rate) * v / np.cos(x[2])

    def __call__(self, x, j: int, out) -> None:
        """dx/dt (4, n) of the states ``x`` (4, n) at half step ``j`` into ``out`` (4, n)."""
        psi, psi_dot, beta = x[0], x[1], x[2]
        sin_b, cos_b, t, q, F = self._sin_b, self._cos_b, self._t, self._q, self._F
        v, inv_mv, a_v = self._at(j)
        np.sin(beta, sin_b)
        np.cos(beta, cos_b)
        # slip angles -arctan((v sin beta + lever psi_dot) / (v cos beta)), + delta at the front
        np.multiply(self.lever, psi_dot, q)
        np.multiply(sin_b, v, t)
        q += t
        np.multiply(cos_b, v, t)
        q /= t
        np.arctan(q, q)
        np.negative(q, q)
        q[0] += self.delta_half[j]
        if self.saturating:  # D sin(C arctan(B a - E (B a - arctan(B a))))
            bx = self._bx
            np.multiply(self.Bs, q, bx)
            np.arctan(bx, F)
            np.subtract(bx, F, F)
            F *= self.E
            np.subtract(bx, F, F)
            np.arctan(F, F)
            F *= self.C
            np.sin(F, F)
            F *= self.peak
        else:
            np.multiply(self.linear, q, F)
        fc, tmp = self._fc, self._tmp
        F_w = self.F_w_half[j]
        np.multiply(F[0], self.cos_delta[j], fc)  # F_f cos delta
        out[0] = psi_dot
        o1 = out[1]  # (l_f F_f cos delta - l_r F_r + M_w) / I_z
        np.multiply(self.l_f, fc, o1)
        np.multiply(self.l_r, F[1], tmp)
        o1 -= tmp
        if self.M_w is None:
            np.multiply(F_w, self.M_c, tmp)
            o1 += tmp
        else:
            o1 += self.M_w
        o1 *= self.inv_I_z
        o2 = out[2]  # (F_f cos delta + F_r + F_w) cos beta / (m v) - psi_dot + a_lat / v
        np.add(fc, F[1], o2)
        o2 += F_w
        o2 *= cos_b
        o2 *= inv_mv
        o2 -= psi_dot
        o2 += a_v
        if self.speed_half is not None:
            o2 -= self.speed_half[1][j] / v * sin_b
        o3 = out[3]  # v sin(psi + k beta)
        np.multiply(beta, self.k, o3)
        o3 += psi
        np.sin(o3, o3)
        o3 *= v


def integrate_single_track(p: VehicleParameters, s: ModelStructure, E, delta_half, F_w_half, yaw_gust: bool, wind, h: float,
                           n_steps: int, record_every: int, speed_half=None):
    """States of the single-track model from rest by RK4.

    Parameters
    ----------
    p, s, E, delta_half, F_w_half, yaw_gust, wind
        As :class:`SingleTrackRHS`; the half-step grids hold 2 ``n_steps`` + 1 points.
    h : float
        RK4 step (s).
    n_steps, record_every : int
        Steps, and the stride of the returned states (``n_steps`` a multiple of it).
    speed_half : tuple of two ndarrays, shape (2 ``n_steps`` + 1,), optional
        A speed profile (v, v_dot) per half step (:class:`SingleTrackRHS`).

    Returns
    -------
    ndarray, shape (n_steps // record_every + 1, 4, n)
        psi, psi_dot, beta, y (rad, rad/s, rad, m) every ``record_every`` steps from t = 0.
    """
    rhs = SingleTrackRHS(p, s, E, delta_half, F_w_half, yaw_gust, wind, speed_half)
    return rk4_fixed_step_into(rhs, np.zeros((4, F_w_half.shape[1])), h, n_steps, record_every)

"""RK4 of the single-track model for the augmented simulator
(:class:`uqdrive.vehicle.augmented.AugmentedSimulator`): the non-linear model's right-hand side
(:class:`uqdrive.vehicle.dynamics.rhs.SingleTrackRHS`) integrated, and the linear model along a speed profile.

What the sensors of an augmented single-track model record: the lateral acceleration a_y beside
the states, and the linear model along a speed profile v(t) (past the thesis).

a_y is what an accelerometer at the centre of gravity reads, the specific force: the lateral
tyre and wind forces over the mass, (F_f cos delta + F_r + F_w) / m. At constant speed and on a
level road it equals v (beta_dot + psi_dot); on a banked road the gravity component g sin(phi)
acts on the body and on the sensor alike, so the sensor does not feel it (a bank shows in a_y as
the tyre force that holds the car against it); while the speed changes the kinematic
acceleration gains v_dot beta (:func:`uqdrive.vehicle.single_track.lateral_acceleration_map`).

Along a speed profile the linear single-track model (5.4) is time-varying: its matrices follow
v(t) and the side-slip equation gains -v_dot / v beta (:func:`lst_matrices_at_speed`). The
augmented simulator integrates it by fixed-step RK4 on the forces (every realisation at once),
as its non-linear tyre.
"""

from __future__ import annotations

import numpy as np

from ..numerics.integrate import rk4_fixed_step_into
from .dynamics.rhs import SingleTrackRHS
from .single_track import (STATES, VehicleParameters, linear_axle_forces, lst_lateral_acceleration, lst_speed_coefficients, wind_yaw_moment,
                           with_compliance_steer)

__all__ = ["integrate_single_track", "speed_on_half_steps", "linear_lateral_acceleration", "LinearTrackRHS",
           "integrate_linear_ltv", "rk4_lateral_acceleration", "measured_channels"]


def integrate_single_track(rhs: SingleTrackRHS, h: float, n_steps: int, record_every: int):
    """States of the single-track model ``rhs`` from rest by RK4.

    Parameters
    ----------
    rhs : SingleTrackRHS
        The right-hand side with its inputs on the half-step grid (2 ``n_steps`` + 1 points).
    h : float
        RK4 step (s).
    n_steps, record_every : int
        Steps, and the stride of the returned states (``n_steps`` a multiple of it).

    Returns
    -------
    ndarray, shape (n_steps // record_every + 1, 4, n)
        psi, psi_dot, beta, y (rad, rad/s, rad, m) every ``record_every`` steps from t = 0 (psi
        and y NaN where ``rhs`` leaves them out).
    """
    step = rk4_fixed_step_into
    if getattr(rhs, "fused", False):  # numba is loaded: the stepper's arithmetic compiled too, the same numbers
        from .dynamics.fused_rk4 import rk4_fused_into as step
    return _with_heading(step(rhs, np.zeros((rhs.n_states, rhs.n)), h, n_steps, record_every))


def _with_heading(out):
    """Recorded states (K + 1, 4, n): those of psi_dot and beta alone (K + 1, 2, n) with psi and y NaN."""
    if out.shape[1] == 4:
        return out
    full = np.empty((out.shape[0], 4, out.shape[2]))  # each row written once (a 10 s run of 2400 realisations: 77 MB)
    full[:, 0] = full[:, 3] = np.nan
    full[:, 1:3] = out
    return full


def speed_on_half_steps(time, speed, t_half):
    """Speed v (m/s) and its rate v_dot (m/s^2) on the RK4 half-step grid, shape (J,) each.

    Parameters
    ----------
    time, speed : ndarray, shape (T,)
        The measured grid (s) and the speed on it (m/s), linear between samples.
    t_half : ndarray, shape (J,)
        Half-step times (s).
    """
    v = np.interp(t_half, time, speed)
    slope = np.diff(speed) / np.diff(time)
    i = np.clip(np.searchsorted(time, t_half, side="right") - 1, 0, slope.size - 1)
    v_dot = slope[i]
    # at a sample the slopes on either side meet: their mean (a kink of a ramp's ends)
    on = np.isclose(t_half, time[np.clip(np.searchsorted(time, t_half), 0, time.size - 1)], rtol=0, atol=1e-12)
    k = np.clip(np.searchsorted(time, t_half), 1, slope.size)
    both = 0.5 * (slope[k - 1] + slope[np.minimum(k, slope.size - 1)])
    return v, np.where(on, both, v_dot)


def linear_lateral_acceleration(p: VehicleParameters, x, delta, F_w, v, compliance_steer: float = 0.0):
    """a_y (m/s^2) of the linear single-track model (5.4), (F_f + F_r + F_w) / m, of simulated states
    (:func:`~uqdrive.vehicle.single_track.lst_lateral_acceleration`).

    Parameters
    ----------
    p : VehicleParameters
        Per-realisation parameters (arrays of shape (n,) or scalars).
    x : ndarray, shape (4, n, K)
        States psi (rad), psi_dot (rad/s), beta (rad), y (m).
    delta : ndarray, shape (K,)
        Actual road-wheel angle (rad).
    F_w : ndarray, shape (n, K)
        Side wind (N).
    v : float or ndarray, shape (K,)
        Speed (m/s).
    compliance_steer : float
        K (deg/g): the front wheels yield to the front force, a softer front axle
        (:func:`uqdrive.vehicle.single_track.with_compliance_steer`, as the simulator's model).

    Returns
    -------
    ndarray, shape (n, K)
    """
    return lst_lateral_acceleration(with_compliance_steer(p, compliance_steer), np.asarray(delta, float), x[2], x[1], F_w, v)


class LinearTrackRHS:
    """dx/dt of the linear single-track model (5.4) along a speed profile, for n realisations.

    (5.4) at the local speed v_j, its coefficients with the speed factored out
    (:func:`~uqdrive.vehicle.single_track.lst_speed_coefficients`): psi_ddot = (l_f F_f - l_r F_r + M_w) / I_z,
    beta_dot = (F_f + F_r + F_w) / (m v) - psi_dot - (v_dot / v) beta + a_lat / v, the forces of
    :func:`~uqdrive.vehicle.single_track.linear_axle_forces`; y_dot = v (psi + k beta), or
    v sin(psi + k beta) for the exact course kinematics.

    The simulators integrate it by a compiled pass (:func:`integrate_linear_ltv`) that performs
    these operations in this order: calling it (``rk4_fixed_step_into``) gives the same numbers,
    bit for bit, and is the reference the compiled pass is tested against.

    Parameters
    ----------
    p : VehicleParameters
        Per-realisation parameters.
    s : ModelStructure
        ``course_weight``, ``course_exact``, ``lateral_acceleration`` (m/s^2), ``compliance_steer`` (deg/g).
    delta_half : ndarray, shape (J,)
        Actual steering angle (rad) on the half-step grid.
    F_w_half : ndarray, shape (J, n)
        Side wind (N) per half step and realisation.
    yaw_gust : bool
        The gusts exert the yaw moment M_c F_w too (else M_c times the mean wind).
    wind : ndarray, shape (n,)
        Mean wind (N).
    v_half, v_dot_half : ndarray, shape (J,)
        Speed (m/s) and its rate (m/s^2) per half step.
    heading : bool
        Integrate psi and y too; False: the states are psi_dot and beta alone (2, n), which
        neither psi nor y enters, for sensors that record neither (the same numbers for both).
    """

    def __init__(self, p: VehicleParameters, s, delta_half, F_w_half, yaw_gust: bool, wind, v_half, v_dot_half, heading: bool = True):
        self.heading, self.n_states = bool(heading), 4 if heading else 2
        self._rows = (1, 2) if heading else (0, 1)  # psi_dot's and beta's rows of the integrated states
        p = with_compliance_steer(p, s.compliance_steer)  # the steering's compliance: a softer front axle
        k = np.asarray(s.course_weight, float)  # per realisation where pairs share a pass
        self.p, self.k, self.exact = p, (float(k) if k.ndim == 0 else k), bool(s.course_exact)
        self.a_lat = np.asarray(s.lateral_acceleration, float)
        self._has_lat = bool(np.any(self.a_lat))
        self.delta_half, self.F_w_half = np.asarray(delta_half, float), F_w_half
        self.v_half, self.v_dot_half = np.asarray(v_half, float), np.asarray(v_dot_half, float)
        self.coefficients = c = lst_speed_coefficients(p)
        n = F_w_half.shape[1]
        as_n = lambda a: np.broadcast_to(np.asarray(a, float), (n,)).copy()  # noqa: E731
        # psi_ddot = (P / v) r + a12 beta + a13 d + M_w / I_z,
        # beta_dot = (Q / v^2 - 1) r + (R / v - v_dot / v) beta + (S / v) d + F_w / (m v) + a_lat / v
        self.P, self.a12, self.a13, self.W1 = as_n(c.yaw_damping), as_n(c.yaw_slip), as_n(c.yaw_steer), as_n(c.yaw_wind)
        self.Q, self.R, self.S, self.inv_m = as_n(c.slip_yaw), as_n(c.slip_damping), as_n(c.slip_steer), as_n(c.slip_wind)
        self.M_term = None if yaw_gust else as_n(wind_yaw_moment(p.M_c, np.asarray(wind, float), 0.0, False) / c.I_z)
        self.inv_v = [float(1.0 / v) for v in self.v_half]
        self.rate = [float(vd / v) for v, vd in zip(self.v_half, self.v_dot_half)]
        self._t = np.empty(n)
        # the terms that do not depend on the state, at the last half step asked for: RK4 asks for
        # every half step twice in a row (k2 and k3; k4 and the next step's k1)
        self._j, self._terms = -1, np.empty((5, n))

    def _inputs(self, j: int):
        """a13 delta, W1 F_w, S (delta / v), F_w / (m v) and a_lat / v (5, n) at half step ``j``."""
        if j != self._j:
            iv, d, F_w, u = self.inv_v[j], float(self.delta_half[j]), self.F_w_half[j], self._terms
            np.multiply(self.a13, d, u[0])
            if self.M_term is None:
                np.multiply(self.W1, F_w, u[1])
            np.multiply(self.S, d * iv, u[2])
            np.multiply(self.inv_m, F_w, u[3])
            u[3] *= iv
            if self._has_lat:
                np.multiply(self.a_lat, iv, u[4])
            self._j = j
        return self._terms

    def forces(self, x, j: int):
        """Front and rear tyre forces (N), each shape (n,), at half step ``j``."""
        return linear_axle_forces(self.coefficients, self.delta_half[j], x[2], x[1], self.v_half[j])

    def __call__(self, x, j: int, out) -> None:
        """dx/dt (4, n) of ``x`` (4, n) at half step ``j`` into ``out``."""
        i_r, i_b = self._rows
        r, b, t = x[i_r], x[i_b], self._t
        iv, rate, u = self.inv_v[j], self.rate[j], self._inputs(j)
        o1, o2 = out[i_r], out[i_b]
        np.multiply(self.P, r, o1)
        o1 *= iv
        np.multiply(self.a12, b, t)
        o1 += t
        o1 += u[0]
        o1 += u[1] if self.M_term is None else self.M_term
        np.multiply(self.Q, r, o2)
        o2 *= iv * iv
        o2 -= r
        np.multiply(self.R, b, t)
        t *= iv
        o2 += t
        np.multiply(b, rate, t)
        o2 -= t
        o2 += u[2]
        o2 += u[3]
        if self._has_lat:
            o2 += u[4]
        if not self.heading:
            return
        out[0] = r
        o3 = out[3]
        np.multiply(b, self.k, o3)
        o3 += x[0]
        if self.exact:
            np.sin(o3, o3)
        o3 /= iv

    def lateral_acceleration(self, x, j: int):
        """a_y (m/s^2), shape (n,), of ``x`` (4, n) at half step ``j``: (F_f + F_r + F_w) / m."""
        return lst_lateral_acceleration(self.coefficients, self.delta_half[j], x[2], x[1], self.F_w_half[j], self.v_half[j])

    def lateral_acceleration_along(self, x, js):
        """a_y (m/s^2), shape (n, K + 1), of the states ``x`` (4, n, K + 1) at the half steps ``js``
        (K + 1,): :meth:`lateral_acceleration` of every time in one element-wise pass (the same
        operations on each element, so the same numbers)."""
        js = np.asarray(js)
        return lst_lateral_acceleration(self.coefficients, self.delta_half[js], x[2], x[1], self.F_w_half[js].T, self.v_half[js])


def integrate_linear_ltv(rhs: LinearTrackRHS, h: float, n_steps: int, record_every: int):
    """States (4, n, K + 1) of ``rhs`` from rest by RK4 (step h, recorded every ``record_every``);
    psi and y NaN where ``rhs`` leaves them out (``heading`` False).

    The pass is compiled (:func:`uqdrive.vehicle.dynamics.ltv_rk4.rk4_linear_track`): the numbers
    of ``rk4_fixed_step_into(rhs, ...)`` bit for bit, without NumPy's cost per call on every stage.
    """
    from .dynamics.ltv_rk4 import rk4_linear_track  # numba: only where a speed profile is integrated

    out = rk4_linear_track(h, n_steps, record_every, heading=rhs.heading, exact=rhs.exact, P=rhs.P, a12=rhs.a12, a13=rhs.a13, W1=rhs.W1,
                           Q=rhs.Q, R=rhs.R, S=rhs.S, inv_m=rhs.inv_m, M_term=rhs.M_term, a_lat=rhs.a_lat, k=rhs.k,
                           delta_half=rhs.delta_half, F_w_half=rhs.F_w_half, inv_v=rhs.inv_v, rate=rhs.rate, padded=True)
    return out.transpose(1, 2, 0)


def rk4_lateral_acceleration(rhs, x, js):
    """a_y (m/s^2), shape (n, K + 1), of RK4 states x (4, n, K + 1) from the right-hand side
    ``rhs`` (its ``lateral_acceleration(x, j)``, or ``lateral_acceleration_along(x, js)`` at
    every time at once) at the half-step indices ``js`` (K + 1,)."""
    if hasattr(rhs, "lateral_acceleration_along"):
        return rhs.lateral_acceleration_along(x, js)
    return np.stack([rhs.lateral_acceleration(np.ascontiguousarray(x[:, :, k]), j) for k, j in enumerate(js)], axis=-1)


def measured_channels(x, a_y, structure, channels):
    """The ``channels`` (C, n, K + 1) as measured: states x (4, n, K + 1) and a_y (n, K + 1) (None
    when not measured) in the channels' order, with the structure's gain and offset
    (:meth:`uqdrive.vehicle.effects.ModelStructure.output_map`)."""
    gain, offset = structure.output_map(channels)
    out = np.empty((len(channels),) + x.shape[1:])
    for r, c in enumerate(channels):  # in place: np.stack's copy and the product's temporary cost as much as the arithmetic
        np.multiply(a_y if c == "a_y" else x[STATES.index(c)], gain[r], out=out[r])
    out += offset[:, None, None]
    return out

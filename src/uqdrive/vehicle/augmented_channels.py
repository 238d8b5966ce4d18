"""What the sensors of an augmented single-track model record: the lateral acceleration a_y beside
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
from .single_track import VehicleParameters
from .track_extended import compliance_gain

__all__ = ["speed_on_half_steps", "linear_lateral_acceleration", "LinearTrackRHS", "integrate_linear_ltv"]


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
    """a_y (m/s^2) of the linear single-track model (5.4): (F_f + F_r + F_w) / m.

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
        K (deg/g): the front wheels steer by -K a_y with a_y ~ v psi_dot (as the simulator's model).

    Returns
    -------
    ndarray, shape (n, K)
    """
    col = lambda a: np.asarray(a, float)[..., None] if np.ndim(a) else float(a)  # noqa: E731 (per realisation: a column)
    psi_dot, beta = x[1], x[2]
    l_f, l_r, c_f, c_r, m = col(p.l_f), col(p.l_r), col(p.c_f), col(p.c_r), col(p.m)
    d = np.asarray(delta, float) - compliance_gain(compliance_steer, p.g) * v * psi_dot
    F_f = c_f * (d - beta - l_f * psi_dot / v)
    F_r = c_r * (l_r * psi_dot / v - beta)
    return (F_f + F_r + F_w) / m


class LinearTrackRHS:
    """dx/dt of the linear single-track model (5.4) along a speed profile, for n realisations.

    Slip angles and forces as (5.4) at the local speed v_j: F_f = c_f (delta - beta - l_f psi_dot / v),
    F_r = c_r (l_r psi_dot / v - beta); psi_ddot = (l_f F_f - l_r F_r + M_w) / I_z,
    beta_dot = (F_f + F_r + F_w) / (m v) - psi_dot - (v_dot / v) beta + a_lat / v,
    y_dot = v (psi + k beta), or v sin(psi + k beta) for the exact course kinematics.

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
    """

    def __init__(self, p: VehicleParameters, s, delta_half, F_w_half, yaw_gust: bool, wind, v_half, v_dot_half):
        self.p, self.k, self.exact = p, float(s.course_weight), bool(s.course_exact)
        self.a_lat = float(s.lateral_acceleration)
        self.K = compliance_gain(float(s.compliance_steer), p.g)
        self.delta_half, self.F_w_half = np.asarray(delta_half, float), F_w_half
        self.M_w = None if yaw_gust else p.M_c * np.asarray(wind, float)
        self.v_half, self.v_dot_half = np.asarray(v_half, float), np.asarray(v_dot_half, float)
        self.l_f, self.l_r, self.c_f, self.c_r = np.asarray(p.l_f, float), p.l_r, p.c_f, p.c_r
        self.m, self.I_z = p.m, p.I_z

    def forces(self, x, j: int):
        """Front and rear tyre forces (N), each shape (n,), at half step ``j``."""
        v, psi_dot, beta = self.v_half[j], x[1], x[2]
        d = self.delta_half[j] - self.K * v * psi_dot
        return self.c_f * (d - beta - self.l_f * psi_dot / v), self.c_r * (self.l_r * psi_dot / v - beta)

    def __call__(self, x, j: int, out) -> None:
        """dx/dt (4, n) of ``x`` (4, n) at half step ``j`` into ``out``."""
        v, v_dot = self.v_half[j], self.v_dot_half[j]
        F_f, F_r = self.forces(x, j)
        F_w = self.F_w_half[j]
        M_w = self.p.M_c * F_w if self.M_w is None else self.M_w
        out[0] = x[1]
        out[1] = (self.l_f * F_f - self.l_r * F_r + M_w) / self.I_z
        out[2] = (F_f + F_r + F_w) / (self.m * v) - x[1] - (v_dot / v) * x[2] + self.a_lat / v
        c = x[0] + self.k * x[2]
        out[3] = v * (np.sin(c) if self.exact else c)

    def lateral_acceleration(self, x, j: int):
        """a_y (m/s^2), shape (n,), of ``x`` (4, n) at half step ``j``: (F_f + F_r + F_w) / m."""
        F_f, F_r = self.forces(x, j)
        return (F_f + F_r + self.F_w_half[j]) / self.m


def integrate_linear_ltv(rhs: LinearTrackRHS, h: float, n_steps: int, record_every: int):
    """States (4, n, K + 1) of ``rhs`` from rest by RK4 (step h, recorded every ``record_every``)."""
    out = rk4_fixed_step_into(rhs, np.zeros((4, rhs.F_w_half.shape[1])), h, n_steps, record_every)
    return out.transpose(1, 2, 0)

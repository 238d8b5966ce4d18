"""An independent single-track car with real tyres: Magic-Formula tyres whose peak and cornering
stiffness depend on the load, longitudinal load transfer, wheel spin dynamics, combined slip and a
drive torque from a speed-holding controller; vectorised over runs, integrated by its own RK4.

It is a reality of the discovery benchmarks, so it shares no code with the single-track models
under test (:mod:`uqdrive.vehicle.single_track`, :mod:`uqdrive.vehicle.augmented`), not even the stepper.

Equations (body frame x forward, y left; axle i = f, r at x_f = l_f, x_r = -l_r; Rajamani, *Vehicle
Dynamics and Control*, eqs. (2.27)-(2.29) and (13.1)-(13.5))::

    m (v_x' - r v_y) = F_xf cos(delta) - F_yf sin(delta) + F_xr - F_res
    m (v_y' + r v_x) = F_xf sin(delta) + F_yf cos(delta) + F_yr + F_w
    I_z r'           = l_f (F_xf sin(delta) + F_yf cos(delta)) - l_r F_yr + M_w
    I_w,i omega_i'   = T_i - R F_x,i,   psi' = r,   Y' = v_x sin(psi) + v_y cos(psi)

- slips: alpha_f = delta - atan((v_y + l_f r) / v_x), alpha_r = -atan((v_y - l_r r) / v_x) and
  kappa_i = (R omega_i - u_i) / u_i, u_i the wheel's speed along its plane;
- loads: F_zf = m (g l_r - a_x h) / L, F_zr = m (g l_f + a_x h) / L, a_x the body's acceleration
  along x from the forces (a quasi-static pitch, the loop solved by three fixed-point steps);
- tyres: :mod:`.pacejka_tyre`, nominal loads F_z0 those of the nominal car at rest;
- drive: rear wheels, T_r = R (m (k_p e + k_i z) + F_res), e = v_ref - v_x, z' = e, front wheels
  free; resistance F_res = f_r m g + rho C_d A v_x^2 / 2.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .pacejka_tyre import combined, cornering_stiffness, peak, pure_lateral, pure_longitudinal

__all__ = ["PacejkaCar", "PacejkaRHS", "simulate_pacejka", "STATE_ROWS"]

#: State rows: yaw angle, yaw rate, v_x, v_y, lateral position, front and rear wheel speeds, speed-error integral.
STATE_ROWS = ("psi", "r", "v_x", "v_y", "Y", "omega_f", "omega_r", "z")


@dataclass(frozen=True)
class PacejkaCar:
    """Constants of the car (SI units); the chassis and lateral tyre shape are the packaged sedan's.

    Attributes
    ----------
    m_base, J0, wheelbase, B_f, B_r, C, E, M_c, g
        As the vehicle section: kg, m^2 (I_z = J0 m), m, -, -, -, -, m, m/s^2. The lateral
        cornering stiffness at the nominal load is B_i C mu F_z0,i.
    m_load_nominal, l_f_nominal : float
        The nominal car (kg, m) whose static axle loads are the tyres' F_z0.
    cg_height : float
        h (m).
    p_Dz, q_Ky : float
        Load sensitivity of the peak (-) and the load of the largest cornering stiffness (x F_z0).
    k_x, C_x : float
        Slip stiffness per unit load (-) and the longitudinal shape factor (-).
    wheel_radius, wheel_inertia : float
        R (m) and I_w (kg m^2) of an axle's two wheels together.
    k_p, k_i : float
        Speed controller gains (1/s, 1/s^2), per unit mass; 0, 0: no drive torque.
    rolling_resistance, drag_area, air_density : float
        f_r (-), C_d A (m^2), rho (kg/m^3).
    """

    m_base: float = 1784.0
    J0: float = 0.84
    wheelbase: float = 2.85
    B_f: float = 10.6
    B_r: float = 30.4
    C: float = 1.9
    E: float = 0.97
    M_c: float = -1.2
    g: float = 9.81
    m_load_nominal: float = 100.0
    l_f_nominal: float = 1.55
    cg_height: float = 0.55
    p_Dz: float = -0.15
    q_Ky: float = 1.6
    k_x: float = 20.0
    C_x: float = 1.65
    wheel_radius: float = 0.31
    wheel_inertia: float = 2.4
    k_p: float = 2.0
    k_i: float = 1.0
    rolling_resistance: float = 0.012
    drag_area: float = 0.7
    air_density: float = 1.2

    def nominal_loads(self) -> np.ndarray:
        """F_z0 (N) of the front and rear axle, shape (2, 1): the nominal car's static loads."""
        m = self.m_base + self.m_load_nominal
        return np.array([[m * self.g * (self.wheelbase - self.l_f_nominal)], [m * self.g * self.l_f_nominal]]) / self.wheelbase

    def right_hand_side(self, *args) -> "PacejkaRHS":
        """The car's :class:`PacejkaRHS` of ``args`` (its arguments after the car)."""
        return PacejkaRHS(self, *args)


class PacejkaRHS:
    """dx/dt (8, n) of the car for runs with friction ``mu``, load ``m_load`` (kg) and ``l_f`` (m),
    each of shape (n,); ``delta``, ``F_w``, ``M_w`` functions of the half-step index giving the
    steer angle (rad), side force (N) and yaw moment (N m), each broadcasting to (n,); ``v_ref``
    (m/s) the controller's target; ``torque`` (2, n) or (2, 1) extra wheel torques (N m)."""

    def __init__(self, car: PacejkaCar, mu, m_load, l_f, delta, F_w, M_w, v_ref: float, torque=0.0):
        self.car, self.mu = car, np.asarray(mu, float)
        self.m = car.m_base + np.asarray(m_load, float)
        self.l_f = np.asarray(l_f, float)
        self.l_r = car.wheelbase - self.l_f
        self.I_z = car.J0 * self.m
        self.F_z0 = car.nominal_loads()
        self.K_y0 = np.array([[car.B_f], [car.B_r]]) * car.C * self.mu * self.F_z0  # (2, n) at the nominal loads
        self.delta, self.F_w, self.M_w, self.v_ref = delta, F_w, M_w, float(v_ref)
        self.torque = np.asarray(torque, float) * np.ones((2, 1))

    def resistance(self, v_x):
        """F_res (N): rolling resistance and aerodynamic drag at speed ``v_x`` (m/s)."""
        c = self.car
        return c.rolling_resistance * self.m * c.g + 0.5 * c.air_density * c.drag_area * v_x * v_x

    #: Rows of the state: :data:`STATE_ROWS` (a richer car's right-hand side appends its own).
    n_states = len(STATE_ROWS)

    def kinematic_slip(self, x, delta):
        """Slip angles (2, n) (rad) of the wheels' velocities at state ``x`` and steer angle ``delta`` (n,)."""
        r, v_x, v_y = x[1], x[2], x[3]
        return np.stack([delta - np.arctan((v_y + self.l_f * r) / v_x), -np.arctan((v_y - self.l_r * r) / v_x)])

    def slip_angles(self, x, kinematic):
        """The slip angles (2, n) (rad) the tyres' forces follow: the ``kinematic`` ones."""
        return kinematic

    def forces(self, x, j):
        """Tyre forces F_x, F_y (2, n) each (N) in the wheels' frames, loads F_z (2, n) (N), slips
        kappa, alpha (2, n) and the steer angle (n,) at state ``x`` (8, n) and half step ``j``."""
        c = self.car
        r, v_x, v_y, om = x[1], x[2], x[3], x[5:7]
        delta = np.broadcast_to(self.delta(j), v_x.shape)
        alpha = self.slip_angles(x, self.kinematic_slip(x, delta))
        u = np.stack([v_x * np.cos(delta) + (v_y + self.l_f * r) * np.sin(delta), v_x])
        kappa = (c.wheel_radius * om - u) / np.maximum(np.abs(u), 1.0)
        a_x = np.zeros_like(v_x)
        F_res = self.resistance(v_x)
        for _ in range(3):  # loads from a_x, a_x from the forces on those loads
            shift = self.m * a_x * c.cg_height / c.wheelbase
            F_z = np.maximum(np.stack([self.m * c.g * self.l_r / c.wheelbase - shift, self.m * c.g * self.l_f / c.wheelbase + shift]), 0.0)
            D = peak(F_z, self.F_z0, self.mu, c.p_Dz)
            F_y0 = pure_lateral(alpha, D, cornering_stiffness(F_z, self.F_z0, self.K_y0, c.q_Ky), c.C, c.E)
            F_x0 = pure_longitudinal(kappa, D, c.k_x * F_z, c.C_x)
            F_x, F_y = combined(F_x0, F_y0, kappa, alpha)
            a_x = (F_x[0] * np.cos(delta) - F_y[0] * np.sin(delta) + F_x[1] - F_res) / self.m  # = v_x' - r v_y
        return F_x, F_y, F_z, kappa, alpha, delta

    def __call__(self, x, j):
        return self.derivatives(x, j, *self.forces(x, j))

    def derivatives(self, x, j, F_x, F_y, F_z, kappa, alpha, delta):
        """dx/dt (``n_states``, n) at state ``x`` and half step ``j`` of the tyre forces
        F_x, F_y (2, n) (N) and the steer angle ``delta`` (n,) (rad) of :meth:`forces`."""
        c = self.car
        r, v_x, v_y, psi = x[1], x[2], x[3], x[0]
        F_res = self.resistance(v_x)
        F_w = self.F_w(j)
        lat_f = F_x[0] * np.sin(delta) + F_y[0] * np.cos(delta)
        e = self.v_ref - v_x
        drive = c.wheel_radius * (self.m * (c.k_p * e + c.k_i * x[7]) + F_res) if (c.k_p or c.k_i) else 0.0
        out = np.empty_like(x)
        out[0] = r
        out[1] = (self.l_f * lat_f - self.l_r * F_y[1] + self.M_w(j)) / self.I_z
        out[2] = (F_x[0] * np.cos(delta) - F_y[0] * np.sin(delta) + F_x[1] - F_res) / self.m + r * v_y
        out[3] = (lat_f + F_y[1] + F_w) / self.m - r * v_x
        out[4] = v_x * np.sin(psi) + v_y * np.cos(psi)
        out[5] = (self.torque[0] - c.wheel_radius * F_x[0]) / c.wheel_inertia
        out[6] = (drive + self.torque[1] - c.wheel_radius * F_x[1]) / c.wheel_inertia
        out[7] = e
        return out

    def lateral_acceleration(self, x, j):
        """a_y (m/s^2), shape (n,): the specific force an accelerometer at the centre of gravity reads."""
        F_x, F_y, _, _, _, delta = self.forces(x, j)
        return (F_x[0] * np.sin(delta) + F_y[0] * np.cos(delta) + F_y[1] + self.F_w(j)) / self.m


def simulate_pacejka(car: PacejkaCar, mu, m_load, l_f, delta_half, v_ref: float, F_w_half, M_w_half, h: float, n_steps: int,
                     every: int, torque=0.0):
    """States and a_y of runs from straight driving at ``v_ref`` by RK4 with step ``h`` (s).

    Parameters
    ----------
    car : PacejkaCar
    mu, m_load, l_f : ndarray, shape (n,)
        Friction (-), load (kg) and centre-of-gravity distance to the front axle (m) per run.
    delta_half : ndarray, shape (2 n_steps + 1,) or (2 n_steps + 1, n)
        Road-wheel steer angle (rad) at every half step.
    v_ref : float
        Initial speed and the controller's target (m/s).
    F_w_half, M_w_half : ndarray, shape (2 n_steps + 1, n)
        Side force (N) and its yaw moment (N m) at every half step.
    h : float
        Step (s); the wheels' slip mode needs h R^2 k_x F_z / (I_w v) < 2.8.
    n_steps, every : int
        Steps, and steps between recorded samples.
    torque : float or ndarray, shape (2, 1) or (2, n)
        Extra front and rear wheel torque (N m) throughout (braking: negative).

    Returns
    -------
    x : ndarray, shape (S, n, K + 1)
        The rows of :data:`STATE_ROWS` (and a richer car's own after them: S its right-hand side's
        ``n_states``) at every ``every``-th step, K = n_steps // every.
    a_y : ndarray, shape (n, K + 1)
        Lateral acceleration (m/s^2).
    """
    mu = np.asarray(mu, float)
    n = mu.size
    delta_half = np.asarray(delta_half, float)
    rhs = car.right_hand_side(mu, m_load, l_f, lambda j: delta_half[j], lambda j: F_w_half[j], lambda j: M_w_half[j], v_ref, torque)
    x = np.zeros((rhs.n_states, n))
    x[2] = v_ref
    x[5:7] = v_ref / car.wheel_radius
    K = n_steps // every
    states, a_y = np.empty((rhs.n_states, n, K + 1)), np.empty((n, K + 1))
    states[:, :, 0], a_y[:, 0] = x, rhs.lateral_acceleration(x, 0)
    for k in range(1, n_steps + 1):
        j = 2 * (k - 1)
        k1 = rhs(x, j)
        k2 = rhs(x + 0.5 * h * k1, j + 1)
        k3 = rhs(x + 0.5 * h * k2, j + 1)
        k4 = rhs(x + h * k3, j + 2)
        x = x + h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
        if k % every == 0:
            states[:, :, k // every], a_y[:, k // every] = x, rhs.lateral_acceleration(x, j + 2)
    return states, a_y

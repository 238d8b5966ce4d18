"""An independent four-wheel vehicle: planar body, roll and pitch, four load-dependent
Magic-Formula tyres, tyre relaxation, roll steer and a drive force from a speed-holding PI
controller, vectorised over realisations and integrated by fixed-step RK4.

It is the "reality" of the four-wheel discovery benchmark, so it shares no right-hand side with
the single-track models under test (:mod:`uqdrive.vehicle.single_track`, :mod:`uqdrive.vehicle.augmented`); only the RK4
stepper and the car's constants are common.

Equations (body frame x forward, y left, yaw rate r counter-clockwise; wheel i = FL, FR, RL, RR
at (x_i, y_i) = (l_f, t/2), (l_f, -t/2), (-l_r, t/2), (-l_r, -t/2)):

- planar body (Rajamani, *Vehicle Dynamics and Control*, eqs. (2.27)-(2.29) with four wheels)::

      m (vx' - r vy) = sum F_X,i - F_drag
      m (vy' + r vx) = sum F_Y,i + F_w
      I_z r'         = sum (x_i F_Y,i - y_i F_X,i) + M_c F_w
      psi' = r,  Y' = vx sin(psi) + vy cos(psi)

  with the wheel forces (F_x, F_y) turned by the wheel's steer angle delta_i into the body frame;
- roll phi (positive: body leaning to the right, loading the right wheels) about a roll axis on
  the ground (roll centres at ground level) and pitch theta (positive nose up) about the lateral
  axis under the centre of gravity (Milliken & Milliken ch. 18)::

      (I_x + m h^2) phi''   = h sum F_Y,i + m g h sin(phi)   - K_phi phi - C_phi phi'
      (I_y + m h^2) theta'' = h sum F_X,i + m g h sin(theta) - K_th theta - C_th theta'

  (the lateral acceleration of the sprung mass from roll, h phi'', is left out of the lateral
  balance);
- wheel loads: static share, minus/plus the pitch spring's load (K_th theta + C_th theta') / L on
  the front/rear axle, minus/plus each axle's roll spring load (K_phi,i phi + C_phi,i phi') / t
  on its left/right wheel; in steady state the sums are m h (a_x + g theta) / L and
  m h (a_y + g phi) / t, the textbook m a_x h / L and m a_y h / t plus the centre of gravity's
  shift;
- steer angles: delta - e_f phi at the front, e_r phi at the rear (roll steer, positive e:
  understeer);
- slip angles alpha_i = delta_i - atan((vy + r x_i) / (vx - r y_i)), lagged by the relaxation
  length sigma: alpha_i' = (alpha_ss,i - alpha_i) u_i / sigma (Pacejka sec. 7.2), u_i the wheel's
  longitudinal speed;
- tyre forces: :mod:`.four_wheel_tyre` (load-dependent peak and cornering stiffness, friction
  ellipse); the cornering stiffness at the static load is B_axle C mu F_z0 as the single-track
  model's, so that the car's constants mean the same in both;
- drive force F_d = m (k_p e + k_i z), e = v_ref - |v|, z' = e (PI on speed), split by the drive's
  front share over the driven wheels; rolling resistance f_r F_z,i on every wheel, aerodynamic
  drag 1/2 rho C_d A vx^2 at the centre of gravity's height.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
import numpy as np

from ...numerics.integrate import rk4_fixed_step
from ...settings import Vehicle
from .tyre import cornering_stiffness, friction_ellipse, lateral_force, peak_force

__all__ = ["FourWheelCar", "FourWheelRHS", "simulate_four_wheel", "N_STATES"]

#: State rows: psi, r, vx, vy, Y, phi, phi_dot, theta, theta_dot, z (speed-error integral),
#: then the four lagged slip angles.
PSI, R, VX, VY, Y, PHI, PHI_D, TH, TH_D, Z = range(10)
N_STATES = 14


@dataclass(frozen=True)
class FourWheelCar:
    """Constants of the four-wheel car (SI units); defaults: a 1.8 t saloon.

    Attributes
    ----------
    m_base, J0, wheelbase, B_f, B_r, C, E, M_c, g
        As the single-track model's vehicle section (kg, m^2 = I_z / m, m, -, -, -, -, m, m/s^2).
    cg_height, track_width : float
        h and t (m).
    roll_stiffness_front, roll_stiffness_rear : float
        K_phi,f and K_phi,r (N m/rad); their ratio is the roll-stiffness distribution.
    roll_damping_front, roll_damping_rear : float
        C_phi,f and C_phi,r (N m s/rad).
    roll_inertia, pitch_inertia : float
        I_x and I_y about the centre of gravity (kg m^2).
    pitch_stiffness, pitch_damping : float
        K_th (N m/rad), C_th (N m s/rad).
    p_Dz, q_Ky : float
        Load sensitivity of the peak (-) and the cornering stiffness' load of maximum (x F_z0).
    relaxation_length : float
        sigma (m); 0: no lag.
    roll_steer_front, roll_steer_rear : float
        e_f, e_r (rad of steer per rad of roll; positive: understeer).
    drive_front_share : float
        Share of the drive force on the front wheels (0: rear-wheel drive).
    k_p, k_i : float
        Speed controller gains (1/s, 1/s^2), per unit mass.
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
    cg_height: float = 0.55
    track_width: float = 1.6
    roll_stiffness_front: float = 80e3
    roll_stiffness_rear: float = 60e3
    roll_damping_front: float = 6e3
    roll_damping_rear: float = 4.5e3
    roll_inertia: float = 550.0
    pitch_inertia: float = 2800.0
    pitch_stiffness: float = 250e3
    pitch_damping: float = 20e3
    p_Dz: float = -0.1
    q_Ky: float = 2.0
    relaxation_length: float = 0.4
    roll_steer_front: float = 0.08
    roll_steer_rear: float = 0.0
    drive_front_share: float = 0.0
    k_p: float = 1.0
    k_i: float = 0.25
    rolling_resistance: float = 0.012
    drag_area: float = 0.65
    air_density: float = 1.2

    @classmethod
    def from_vehicle(cls, veh: Vehicle, **overrides) -> "FourWheelCar":
        """The car of the single-track settings ``veh`` (cg_height and track_width are required:
        :meth:`uqdrive.settings.Vehicle.require`); ``overrides`` replace any field."""
        purpose = "the four-wheel vehicle model"
        car = cls(m_base=float(veh.m_base), J0=float(veh.J0), wheelbase=float(veh.wheelbase), B_f=float(veh.c_Sf),
                  B_r=float(veh.c_Sr), C=float(veh.C), E=float(veh.E), M_c=float(veh.M_c), g=float(veh.g),
                  cg_height=veh.require("cg_height", purpose), track_width=veh.require("track_width", purpose))
        return replace(car, **overrides)

    @property
    def roll_stiffness(self) -> float:
        """K_phi = K_phi,f + K_phi,r (N m/rad)."""
        return self.roll_stiffness_front + self.roll_stiffness_rear


class FourWheelRHS:
    """Right-hand side of the four-wheel model for n realisations, inputs on the half-step grid.

    Parameters
    ----------
    car : FourWheelCar
    mu, m_load, l_f : ndarray, shape (n,)
        Friction coefficient (-), load (kg), centre of gravity to front axle (m).
    delta_half : ndarray, shape (J,)
        Commanded front steering angle (rad) at the half steps j h / 2.
    v_ref_half : ndarray, shape (J,)
        Speed the controller holds (m/s).
    F_w_half : ndarray, shape (J, n)
        Lateral wind force (N).
    M_w_half : ndarray, shape (J, n)
        Wind yaw moment (N m).
    """

    def __init__(self, car: FourWheelCar, mu, m_load, l_f, delta_half, v_ref_half, F_w_half, M_w_half):
        self.car = car
        self.mu = np.asarray(mu, float)
        self.m = car.m_base + np.asarray(m_load, float)
        l_f = np.asarray(l_f, float)
        L, t = car.wheelbase, car.track_width
        l_r = L - l_f
        self.I_z = self.m * car.J0
        self.x_w = np.stack([l_f, l_f, -l_r, -l_r])  # (4, n)
        self.y_w = np.array([[0.5 * t], [-0.5 * t], [0.5 * t], [-0.5 * t]])
        F_axle = np.stack([self.m * car.g * l_r / L, self.m * car.g * l_f / L])  # (2, n) static axle loads
        self.F_z0 = 0.5 * F_axle[[0, 0, 1, 1]]  # (4, n)
        B = np.array([[car.B_f], [car.B_f], [car.B_r], [car.B_r]])
        self.K_y0 = B * car.C * self.mu * self.F_z0  # single-track convention: c = F_z B C mu
        self.drive_share = 0.5 * np.array([[car.drive_front_share], [car.drive_front_share],
                                           [1.0 - car.drive_front_share], [1.0 - car.drive_front_share]])
        self.delta_half = np.asarray(delta_half, float)
        self.v_ref_half = np.asarray(v_ref_half, float)
        self.F_w_half, self.M_w_half = F_w_half, M_w_half
        h = car.cg_height
        self.roll_inertia = car.roll_inertia + self.m * h**2
        self.pitch_inertia = car.pitch_inertia + self.m * h**2

    def initial_state(self) -> np.ndarray:
        """Straight driving at v_ref[0] in trim: the integrator holds the drive force that
        balances rolling resistance and drag, the body pitched by that drag's moment."""
        car, n = self.car, self.m.size
        x = np.zeros((N_STATES, n))
        v = self.v_ref_half[0]
        x[VX] = v
        F_drag = 0.5 * car.air_density * car.drag_area * v**2
        x[Z] = (car.rolling_resistance * self.m * car.g + F_drag) / (self.m * car.k_i)
        x[TH] = car.cg_height * F_drag / (car.pitch_stiffness - self.m * car.g * car.cg_height)
        return x

    def evaluate(self, x, j: int):
        """dx/dt (N_STATES, n) at half step ``j`` and the quantities behind it.

        Returns
        -------
        dx : ndarray, shape (N_STATES, n)
        out : dict
            ``F_z`` (4, n) wheel loads (N), ``a_x``, ``a_y`` (n,) accelerations of the body
            (sum of forces over m, m/s^2), ``F_d`` (n,) drive force (N), ``F_y`` (4, n) lateral
            tyre forces (N).
        """
        car, m = self.car, self.m
        r, vx, vy, phi, phi_d, th, th_d = x[R], x[VX], x[VY], x[PHI], x[PHI_D], x[TH], x[TH_D]
        v = np.hypot(vx, vy)
        e = self.v_ref_half[j] - v
        F_d = m * (car.k_p * e + car.k_i * x[Z])
        d = self.delta_half[j]
        steer = np.stack([d - car.roll_steer_front * phi] * 2 + [car.roll_steer_rear * phi] * 2)  # (4, n)
        u = vx - r * self.y_w  # wheel-centre velocities in the body frame
        w = vy + r * self.x_w
        alpha_ss = steer - np.arctan(w / u)
        if car.relaxation_length > 0:
            alpha = x[Z + 1:]
        else:
            alpha = alpha_ss
        pitch_load = (car.pitch_stiffness * th + car.pitch_damping * th_d) / car.wheelbase
        roll_load = np.stack([car.roll_stiffness_front * phi + car.roll_damping_front * phi_d,
                              car.roll_stiffness_rear * phi + car.roll_damping_rear * phi_d]) / car.track_width
        F_z = self.F_z0 + np.stack([-0.5 * pitch_load - roll_load[0], -0.5 * pitch_load + roll_load[0],
                                    0.5 * pitch_load - roll_load[1], 0.5 * pitch_load + roll_load[1]])
        F_z = np.maximum(F_z, 0.0)
        D = peak_force(F_z, self.F_z0, self.mu, car.p_Dz)
        K_y = cornering_stiffness(F_z, self.F_z0, self.K_y0, car.q_Ky)
        F_x, ellipse = friction_ellipse(self.drive_share * F_d - car.rolling_resistance * F_z, D)
        F_y = lateral_force(alpha, D, K_y, car.C, car.E) * ellipse
        cos_s, sin_s = np.cos(steer), np.sin(steer)
        F_X = F_x * cos_s - F_y * sin_s
        F_Y = F_x * sin_s + F_y * cos_s
        sum_X, sum_Y = F_X.sum(axis=0), F_Y.sum(axis=0)
        M_z = (self.x_w * F_Y - self.y_w * F_X).sum(axis=0)
        F_drag = 0.5 * car.air_density * car.drag_area * vx * np.abs(vx)
        F_w = self.F_w_half[j]
        a_x, a_y = (sum_X - F_drag) / m, (sum_Y + F_w) / m
        h, mgh = car.cg_height, m * car.g * car.cg_height
        dx = np.empty_like(x)
        dx[PSI] = r
        dx[R] = (M_z + self.M_w_half[j]) / self.I_z
        dx[VX] = a_x + r * vy
        dx[VY] = a_y - r * vx
        dx[Y] = vx * np.sin(x[PSI]) + vy * np.cos(x[PSI])
        dx[PHI] = phi_d
        dx[PHI_D] = (h * sum_Y + mgh * np.sin(phi) - car.roll_stiffness * phi
                     - (car.roll_damping_front + car.roll_damping_rear) * phi_d) / self.roll_inertia
        dx[TH] = th_d
        dx[TH_D] = (h * sum_X + mgh * np.sin(th) - car.pitch_stiffness * th - car.pitch_damping * th_d) / self.pitch_inertia
        dx[Z] = e
        if car.relaxation_length > 0:
            dx[Z + 1:] = (alpha_ss - alpha) * np.abs(u) / car.relaxation_length
        else:
            dx[Z + 1:] = 0.0
        return dx, {"F_z": F_z, "a_x": a_x, "a_y": a_y, "F_d": F_d, "F_y": F_y}

    def __call__(self, x, j: int):
        return self.evaluate(x, j)[0]


def simulate_four_wheel(car: FourWheelCar, mu, m_load, l_f, delta_half, v_ref_half, F_w_half, M_w_half, h: float, n_steps: int,
                        record_every: int):
    """States of n realisations from straight driving in trim, by RK4 with the fixed step ``h``.

    Parameters
    ----------
    car, mu, m_load, l_f, delta_half, v_ref_half, F_w_half, M_w_half
        As :class:`FourWheelRHS`; the half-step grids hold 2 ``n_steps`` + 1 points.
    h : float
        RK4 step (s).
    n_steps, record_every : int
        Steps, and the stride of the returned samples (``n_steps`` a multiple of it).

    Returns
    -------
    x : ndarray, shape (N_STATES, n, K + 1)
        States every ``record_every`` steps from t = 0 (rows as :data:`N_STATES` lists them).
    extras : dict
        At the same times: ``a_y``, ``a_x`` (n, K + 1) body accelerations (m/s^2), ``F_z``
        (4, n, K + 1) wheel loads (N), ``F_d`` (n, K + 1) drive force (N).
    """
    rhs = FourWheelRHS(car, mu, m_load, l_f, delta_half, v_ref_half, F_w_half, M_w_half)
    x = rk4_fixed_step(rhs, rhs.initial_state(), h, n_steps, record_every)  # (K + 1, N_STATES, n)
    keys = ("a_y", "a_x", "F_z", "F_d")
    extras = {k: [] for k in keys}
    for k in range(x.shape[0]):
        _, out = rhs.evaluate(x[k], 2 * k * record_every)
        for key in keys:
            extras[key].append(out[key])
    extras = {k: np.moveaxis(np.asarray(v), 0, -1) for k, v in extras.items()}
    return np.ascontiguousarray(x.transpose(1, 2, 0)), extras

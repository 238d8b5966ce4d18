"""Single-track vehicle models of the thesis: the parameters, the tyre laws and the linear LST (5.4),
each equation written once as a pure function; the NLST (5.3)'s right-hand side is :mod:`uqdrive.vehicle.dynamics`.
Every function is vectorised over realisations: parameters may be scalars or arrays of shape (n,).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from ..settings import Settings

__all__ = ["STATES", "STATE_UNITS", "STATE_NAMES", "VehicleParameters", "magic_formula", "curvature_argument", "tyre_angle",
           "LSTCoefficients", "lst_speed_coefficients", "linear_axle_forces", "lst_lateral_acceleration", "lst_matrices",
           "steering_input", "lateral_acceleration_map", "lst_matrices_at_speed", "gust_input_column", "input_matrix",
           "wind_yaw_moment", "with_compliance_steer"]

#: State vector x = [psi, psi_dot, beta, y] of (5.3)/(5.4).
STATES = ("psi", "psi_dot", "beta", "y")
STATE_UNITS = {"psi": "rad", "psi_dot": "rad/s", "beta": "rad", "y": "m"}
STATE_NAMES = {"psi": "yaw angle", "psi_dot": "yaw rate", "beta": "vehicle side-slip angle", "y": "lateral position"}


def _as_array(x):
    """Float array of ``x``, or complex if ``x`` is complex (complex-step differentiation)."""
    return np.asarray(x) + 0.0


@dataclass(frozen=True)
class VehicleParameters:
    """Parameters of the single-track model, thesis Tables 5.1 and 5.2.

    The uncertain parameters ``mu``, ``m_load`` and ``l_f`` may be floats or arrays of shape
    (n,), one entry per realisation; every derived quantity then has that shape too.

    Attributes
    ----------
    mu : float or ndarray, shape (n,)
        Tyre-road friction coefficient, the Magic-Formula peak factor D (-).
    m_load : float or ndarray, shape (n,)
        Mass of the load (kg).
    l_f : float or ndarray, shape (n,)
        Distance from the centre of gravity to the front axle (m).
    m_base, J0, wheelbase, c_Sf, c_Sr, v_c, M_c, g, C, E : float
        Base mass (kg), specific yaw inertia I_z/m (m^2), wheelbase L (m), front and rear
        stiffness factors B (-), speed (m/s), yaw moment factor (m), gravity (m/s^2), and the
        Magic-Formula shape and curvature factors (-).
    """

    mu: Any = 1.0
    m_load: Any = 100.0
    l_f: Any = 1.55
    m_base: float = 1784.0
    J0: float = 0.84
    wheelbase: float = 2.85
    c_Sf: float = 10.6
    c_Sr: float = 30.4
    v_c: float = 70.0 / 3.6
    M_c: float = -1.2
    g: float = 9.81
    C: float = 1.9
    E: float = 0.97

    @classmethod
    def from_settings(cls, settings: Settings, **draws) -> "VehicleParameters":
        """Nominal parameters of the settings' car and means; ``draws`` override mu, m_load, l_f."""
        veh, unc = settings.vehicle, settings.uncertainty
        car = {f: getattr(veh, f) for f in ("m_base", "J0", "wheelbase", "c_Sf", "c_Sr", "v_c", "M_c", "g", "C", "E")}
        return cls(**{"mu": unc.mu.mean, "m_load": unc.m_load.mean, "l_f": unc.l_f.mean, **car, **draws})

    @property
    def m(self):
        """Total mass m = m_base + m_load (kg)."""
        return self.m_base + _as_array(self.m_load)

    @property
    def l_r(self):
        """Distance from the centre of gravity to the rear axle, L - l_f (m)."""
        return self.wheelbase - _as_array(self.l_f)

    @property
    def I_z(self):
        """Yaw moment of inertia I_z = m J0 (kg m^2)."""
        return self.m * self.J0

    @property
    def F_fz(self):
        """Static front axle load m g l_r / L (N), (5.3c)."""
        return self.m * self.g * self.l_r / self.wheelbase

    @property
    def F_rz(self):
        """Static rear axle load m g l_f / L (N), (5.3d)."""
        return self.m * self.g * _as_array(self.l_f) / self.wheelbase

    @property
    def c_f(self):
        """Front cornering stiffness F_fz B_f C mu (N/rad), the slope of (2.2) at zero slip."""
        return self.F_fz * self.c_Sf * self.C * _as_array(self.mu)

    @property
    def c_r(self):
        """Rear cornering stiffness F_rz B_r C mu (N/rad)."""
        return self.F_rz * self.c_Sr * self.C * _as_array(self.mu)


def with_compliance_steer(p: VehicleParameters, K_deg_per_g) -> VehicleParameters:
    """Parameters whose linear front tyre carries the steering's compliance.

    The front wheels yield to the front axle's lateral force: delta_f = delta - kappa F_f with
    kappa = K / F_fz (rad/N; K in rad per g, F_fz the static front load), so that at steady
    cornering (F_f = F_fz a_y / g) they turn by -K per g of lateral acceleration. On the linear
    tyre F_f = c_f (alpha_f - kappa F_f) solves to F_f = c_f alpha_f / (1 + kappa c_f): the
    compliance lowers the front cornering stiffness to c_f / (1 + K c_Sf C mu) (Gillespie,
    *Fundamentals of Vehicle Dynamics*, sec. 6 "compliance steer": an effective axle stiffness),
    per realisation and exactly, in transients as at steady state.

    Parameters
    ----------
    p : VehicleParameters
        Scalar or per-realisation parameters (mu of shape () or (n,)).
    K_deg_per_g : float
        Compliance steer K (deg/g), positive out of the turn (understeer).

    Returns
    -------
    VehicleParameters
        ``p`` itself for K = 0; else ``c_Sf`` replaced by c_Sf / (1 + K c_Sf C mu) (shape of mu).
    """
    if not np.any(np.asarray(K_deg_per_g) != 0):
        return p
    # a front axle may not turn into a negative stiffness (K far below the physical range)
    factor = 1.0 + np.deg2rad(K_deg_per_g) * p.c_Sf * p.C * _as_array(p.mu)
    factor = np.where(np.real(factor) < 0.05, 0.05, factor)
    return replace(p, c_Sf=p.c_Sf / factor)


def curvature_argument(bx, E, out=None):
    """The Magic Formula's curved argument u = B x - E (B x - atan(B x)) of (2.2a), the force
    being D sin(C atan(u)): ``bx`` (any shape) is B x (-), ``E`` the curvature factor (-); ``out``
    (``bx``'s shape) takes u without temporaries (the RK4 inner loops pass one). Returns u (-)."""
    if out is None:
        return bx - E * (bx - np.arctan(bx))
    np.arctan(bx, out)
    np.subtract(bx, out, out)
    out *= E
    np.subtract(bx, out, out)
    return out


def tyre_angle(bx, C, E, out=None):
    """The Magic Formula's angle C atan(u) of (2.2a), whose sine is the force per unit peak:
    ``bx`` (any shape) is B x (-), C and E the shape and curvature factors (-; E may be an array
    broadcasting against ``bx``); ``out`` (``bx``'s shape) takes the angle without temporaries (the
    RK4 inner loops pass one). Returns the angle (rad)."""
    if out is None:
        return C * np.arctan(curvature_argument(bx, E))
    curvature_argument(bx, E, out)
    np.arctan(out, out)
    out *= C
    return out


def magic_formula(slip, F_z, B, C, D, E):
    """Pacejka's Magic Formula without shifts, thesis (2.2a) with S_H = S_V = 0.

    Parameters
    ----------
    slip : array_like, any shape
        Slip angle (rad) or slip ratio (-).
    F_z : array_like, shape broadcastable against ``slip``
        Normal load (N).
    B, C, D, E : array_like, shape broadcastable against ``slip``
        Stiffness, shape, peak and curvature factors (-).

    Returns
    -------
    ndarray, the broadcast shape of the arguments
        Tyre force (N), F_z D sin(C atan(B x - E (B x - atan(B x)))).
    """
    return F_z * D * np.sin(tyre_angle(B * slip, C, E))


@dataclass(frozen=True)
class LSTCoefficients:
    """The linear single-track model (5.4) with the speed v factored out, per realisation.

    At the speed v (m/s)::

        psi_ddot = (yaw_damping / v) psi_dot + yaw_slip beta + yaw_steer delta + yaw_wind F_w
        beta_dot = (slip_yaw / v^2 - 1) psi_dot + (slip_damping / v) beta + (slip_steer / v) delta + (slip_wind / v) F_w

    Attributes
    ----------
    l_f, l_r, c_f, c_r, m, I_z, M_c : float or ndarray, shape (n,)
        Axle distances (m), cornering stiffnesses (N/rad), mass (kg), yaw inertia (kg m^2), yaw moment factor (m);
        the coefficients are computed where asked for (a simulator's arrays of thousands of realisations are not all held at once).
    """

    l_f: Any
    l_r: Any
    c_f: Any
    c_r: Any
    m: Any
    I_z: Any
    M_c: float
    @property
    def yaw_stiffness(self):
        """c_f l_f^2 + c_r l_r^2 (N m^2/rad)."""
        return self.c_f * self.l_f**2 + self.c_r * self.l_r**2
    @property
    def stiffness_moment(self):
        """c_r l_r - c_f l_f (N m/rad)."""
        return self.c_r * self.l_r - self.c_f * self.l_f
    @property
    def axle_stiffness(self):
        """c_f + c_r (N/rad)."""
        return self.c_f + self.c_r
    @property
    def yaw_damping(self):
        """-(c_f l_f^2 + c_r l_r^2) / I_z (m/s^2)."""
        return -self.yaw_stiffness / self.I_z
    @property
    def yaw_slip(self):
        """(c_r l_r - c_f l_f) / I_z (1/s^2)."""
        return self.stiffness_moment / self.I_z
    @property
    def yaw_steer(self):
        """l_f c_f / I_z (1/s^2); in this order: a complex step's imaginary part rounds by it."""
        return self.l_f * self.c_f / self.I_z
    @property
    def yaw_wind(self):
        """M_c / I_z (1/(kg m))."""
        return self.M_c / self.I_z
    @property
    def slip_yaw(self):
        """(c_r l_r - c_f l_f) / m (m^2/s^2)."""
        return self.stiffness_moment / self.m
    @property
    def slip_damping(self):
        """-(c_f + c_r) / m (m/s^2)."""
        return -self.axle_stiffness / self.m
    @property
    def slip_steer(self):
        """c_f / m (m/s^2)."""
        return self.c_f / self.m
    @property
    def slip_wind(self):
        """1 / m (1/kg)."""
        return 1.0 / self.m


def lst_speed_coefficients(p: VehicleParameters) -> LSTCoefficients:
    """The coefficients of (5.4) with the speed factored out (:class:`LSTCoefficients`), thesis eq. (5.4) with FACTS'
    corrections: ``p`` scalar or per-realisation (mu, m_load, l_f of shape () or (n,); complex: complex-step derivatives)."""
    return LSTCoefficients(_as_array(p.l_f), p.l_r, p.c_f, p.c_r, p.m, p.I_z, p.M_c)


def _per_realisation(a, ndim: int):
    """``a`` (shape () or (n,)) with trailing axes to broadcast against states of ``ndim`` axes whose first is the realisations'."""
    return a if np.ndim(a) in (0, ndim) else np.reshape(a, np.shape(a) + (1,) * (ndim - np.ndim(a)))


def linear_axle_forces(p, delta, beta, psi_dot, v):
    """Lateral axle forces of the linear tyres at the small slip angles of (5.4), thesis eq. (5.4):
    F_f = c_f (delta - beta - l_f psi_dot / v), F_r = c_r (l_r psi_dot / v - beta).

    Parameters
    ----------
    p : VehicleParameters or LSTCoefficients
        Its l_f, l_r (m), c_f, c_r (N/rad), of shape () or (n,).
    delta, v : float or ndarray
        Front wheel angle (rad) and speed (m/s), broadcasting against ``beta`` (e.g. (K,) against (n, K)).
    beta, psi_dot : ndarray, shape (n, ...) or (n,)
        Side-slip angle (rad) and yaw rate (rad/s); their first axis is the realisations'.

    Returns
    -------
    F_f, F_r : ndarray, the broadcast shape
        Front and rear lateral forces (N).
    """
    l_f, l_r, c_f, c_r = p.l_f, p.l_r, p.c_f, p.c_r
    if np.ndim(beta) > 1:  # realisations by time: a parameter per row
        l_f, l_r, c_f, c_r = (_per_realisation(a, np.ndim(beta)) for a in (l_f, l_r, c_f, c_r))
    return c_f * (delta - beta - l_f * psi_dot / v), c_r * (l_r * psi_dot / v - beta)


def lst_lateral_acceleration(p, delta, beta, psi_dot, F_w, v):
    """a_y = (F_f + F_r + F_w) / m (m/s^2) of the linear single-track model, thesis eq. (5.4): the forces of :func:`linear_axle_forces`
    (same arguments) and the side wind ``F_w`` (N, broadcasting against ``beta``) over the mass (:func:`lateral_acceleration_map`)."""
    F_f, F_r = linear_axle_forces(p, delta, beta, psi_dot, v)
    return (F_f + F_r + F_w) / (p.m if np.ndim(beta) < 2 else _per_realisation(p.m, np.ndim(beta)))


def lst_matrices(p: VehicleParameters):
    """System matrices of the linear single-track model, thesis (5.4) with FACTS' corrections.

    Parameters
    ----------
    p : VehicleParameters
        Scalar or per-realisation parameters; ``mu``, ``m_load``, ``l_f`` of shape () or (n,).

    Returns
    -------
    A : ndarray, shape (..., 4, 4)
        State matrix for x = [psi, psi_dot, beta, y]; row 3 holds (c_r l_r - c_f l_f)/(m v^2) - 1
        in the psi_dot column and row 4 is y_dot = v_c psi.
    B : ndarray, shape (..., 4)
        Steering input column [0, l_f c_f / I_z, c_f / (m v_c), 0] (1/s^2, 1/s per rad).
    W : ndarray, shape (..., 4)
        Side-wind input column per newton, [0, M_c / I_z, 1 / (m v_c), 0], so that the
        disturbance term of (5.4) is W F_w(t).
    """
    c, v = lst_speed_coefficients(p), p.v_c
    shape = np.broadcast_shapes(np.shape(c.m), np.shape(c.l_f), np.shape(c.c_f))
    dtype = np.result_type(c.m, c.l_f, c.c_f, float)  # complex parameters give complex-step derivatives
    A = np.zeros(shape + (4, 4), dtype)
    A[..., 0, 1] = 1.0
    A[..., 1, 1] = -c.yaw_stiffness / (c.I_z * v)
    A[..., 1, 2] = c.yaw_slip
    A[..., 2, 1] = c.stiffness_moment / (c.m * v**2) - 1.0
    A[..., 2, 2] = -c.axle_stiffness / (c.m * v)
    A[..., 3, 0] = v
    B = np.zeros(shape + (4,), dtype)
    B[..., 1] = c.yaw_steer
    B[..., 2] = c.c_f / (c.m * v)
    W = np.zeros(shape + (4,), dtype)
    W[..., 1] = c.yaw_wind
    W[..., 2] = 1.0 / (c.m * v)
    return A, B, W


def steering_input(t, delta_max: float, period: float, sign: float = 1.0):
    """Slalom steering angle delta(t) = sign delta_max cos(2 pi t / period) (rad), thesis (5.5) (``sign=+1``)
    and inverted (5.7) (``sign=-1``), at the times ``t`` (s, shape (T,)) for the amplitude ``delta_max``
    (rad) and ``period`` (s; the thesis' 4 s: cos(pi t / 2)). Returns an ndarray of shape (T,)."""
    return sign * delta_max * np.cos(2.0 * np.pi * np.asarray(t, dtype=float) / period)


#: Lateral acceleration at the centre of gravity, the channel an IMU records besides the yaw rate.
A_Y_UNIT = "m/s^2"


def lateral_acceleration_map(p: VehicleParameters):
    """Output map a_y = C x + D_delta delta + D_w F_w of the linear single-track model.

    a_y is the lateral acceleration of the centre of gravity in the vehicle frame, the lateral forces
    over the mass (:func:`lst_lateral_acceleration`). At constant speed it equals v (beta_dot + psi_dot);
    while the speed changes v (beta_dot + psi_dot) + v_dot beta (the derivative of v_y = v beta). A
    sensor mounted x_s metres ahead of the centre of gravity reads a_y + x_s psi_ddot.

    Parameters
    ----------
    p : VehicleParameters
        Scalar or per-realisation parameters; ``v_c`` may be an array broadcasting with them.

    Returns
    -------
    C : ndarray, shape (..., 4)
        [0, (c_r l_r - c_f l_f) / (m v), -(c_f + c_r) / m, 0] (m/s^2 per unit of each state).
    D_delta : ndarray, shape (...)
        c_f / m (m/s^2 per rad of steering).
    D_w : ndarray, shape (...)
        1 / m (m/s^2 per N of side wind).
    """
    c, v = lst_speed_coefficients(p), p.v_c
    shape = np.broadcast_shapes(np.shape(c.m), np.shape(c.l_f), np.shape(c.c_f), np.shape(v))
    dtype = np.result_type(c.m, c.l_f, c.c_f, float)
    C = np.zeros(shape + (4,), dtype)
    C[..., 1] = c.stiffness_moment / (c.m * v)
    C[..., 2] = c.slip_damping
    return C, np.broadcast_to(c.slip_steer, shape), np.broadcast_to(c.slip_wind, shape)


def lst_matrices_at_speed(p: VehicleParameters, v, v_dot=0.0):
    """:func:`lst_matrices` at the speed ``v`` (m/s) while it changes at ``v_dot`` (m/s^2).

    With v_y = v beta, the lateral balance m (d v_y / dt + v psi_dot) = F_y gives
    beta_dot = F_y / (m v) - psi_dot - (v_dot / v) beta: the state matrix of (5.4) at the local
    speed with -v_dot / v added to its (beta, beta) entry. For v_dot = 0 this is exactly
    :func:`lst_matrices` of ``p`` with ``v_c = v``.
    """
    A, B, W = lst_matrices(replace(p, v_c=v))
    if v_dot:
        A[..., 2, 2] -= v_dot / v
    return A, B, W


def wind_yaw_moment(M_c: float, wind_mean, gust, gust_yaw_moment: bool):
    """Yaw moment of the wind (5.3f): M_c times the whole wind, or its mean only when the
    gusts act laterally only (config ``wind.gust_yaw_moment``)."""
    return M_c * (wind_mean + gust) if gust_yaw_moment else M_c * wind_mean


def input_matrix(steer, constant, gust, coeffs):
    """The LST's input matrix E = [B, W F_w, W_gust c_1, ..., W_gust c_nc], shape (n, 4, 2 + n_c),
    of the shared signals g(t) = [delta(t), 1, f_1(t), ..., f_nc(t)] of (5.4) with (5.1), (5.21):
    ``steer`` B, ``constant`` W F_w_mean (plus an effect's constant term) and ``gust`` W_gust
    (:func:`gust_input_column`) of shape (n, 4), the wind mode coefficients ``coeffs`` (n, n_c) (N)."""
    return np.concatenate([steer[:, :, None], constant[:, :, None], gust[:, :, None] * coeffs[:, None, :]], axis=2)


def gust_input_column(W, gust_yaw_moment: bool):
    """Input column of the time-variant wind: W of (5.4), without its yaw-moment entry when the
    gusts act laterally only (config ``wind.gust_yaw_moment``; see docs/reproduction.md, "Wind yaw moment")."""
    if gust_yaw_moment:
        return W
    W = np.array(W, copy=True)
    W[..., 1] = 0.0
    return W

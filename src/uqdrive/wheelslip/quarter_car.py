"""Wheel-slip control of the GP paper: quarter car (9)-(12), slip dynamics with actuator (14)-(17),
friction curve (26)-(27), PID tuning (22)-(23) and the 95 % damping bounds (24)-(25).
"""

from __future__ import annotations

from dataclasses import dataclass
import numpy as np

from ..settings import WheelSlipCar

__all__ = [
    "QuarterCar",
    "friction_curve",
    "friction_slope",
    "pid_gains",
    "pid_schedule",
    "damping",
    "damping_bounds",
    "closed_loop_poles",
    "simulate_closed_loop",
]


@dataclass(frozen=True)
class QuarterCar:
    """Quarter-car and controller-design constants of the paper (sec. III-C).

    Attributes
    ----------
    r : wheel radius (m); F_z : normal load (N); mass : quarter-car mass (kg); J : wheel
    inertia (kg m^2); T_a : actuator time constant (s); k : friction-curve slope at zero slip
    (-); mu_H : peak friction (-); lambda_star : slip set-point (-); zeta_d : desired damping
    (-); omega_0d : desired bandwidth (rad/s).
    """

    # the paper's car, held once in the settings
    r: float = WheelSlipCar.r
    F_z: float = WheelSlipCar.F_z
    mass: float = WheelSlipCar.mass
    J: float = WheelSlipCar.J
    T_a: float = WheelSlipCar.T_a
    k: float = WheelSlipCar.k
    mu_H: float = WheelSlipCar.mu_H
    lambda_star: float = WheelSlipCar.lambda_star
    zeta_d: float = WheelSlipCar.zeta_d
    omega_0d: float = WheelSlipCar.omega_0d

    @classmethod
    def from_settings(cls, car: WheelSlipCar) -> "QuarterCar":
        """The quarter car of the settings' ``wheelslip``."""
        return cls(**{f: getattr(car, f) for f in cls.__dataclass_fields__})

    @property
    def alpha(self) -> float:
        """alpha = r / J (FACTS: 0.5147, unrounded)."""
        return self.r / self.J

    @property
    def beta(self) -> float:
        """beta = r^2 F_z / J (441.8)."""
        return self.r**2 * self.F_z / self.J


def _curve_coefficients(mu_H, k):
    lam0 = 0.2 * np.asarray(mu_H, float)  # slip of peak friction
    return 1.0 / lam0**2, (k * lam0 - 2.0 * mu_H) / (lam0 * mu_H)


def friction_curve(lam, mu_H: float = 0.9, k: float = 28.0):
    """mu(lambda) = k lambda / (a lambda^2 + b lambda + 1), paper (26)-(27) (FACTS' form).

    a = 1 / lambda_0^2, b = (k lambda_0 - 2 mu_H) / (lambda_0 mu_H), lambda_0 = 0.2 mu_H: the
    curve has slope k at zero slip and peaks at mu_H at lambda_0.
    """
    a, b = _curve_coefficients(mu_H, k)
    lam = np.asarray(lam, float)
    return k * lam / (a * lam**2 + b * lam + 1.0)


def friction_slope(lam, mu_H: float = 0.9, k: float = 28.0):
    """d mu / d lambda = k (1 - a lambda^2) / (a lambda^2 + b lambda + 1)^2 (0.3882 at 0.15)."""
    a, b = _curve_coefficients(mu_H, k)
    lam = np.asarray(lam, float)
    return k * (1.0 - a * lam**2) / (a * lam**2 + b * lam + 1.0) ** 2


def pid_gains(mean_slope, v, car: QuarterCar):
    """PID gains from the expected slope E(Gamma), paper (22)-(23), with T_d = T_a.

    Returns
    -------
    K_p : controller gain (N m per unit slip); T_i : integral time (s); T_d : derivative time (s)
    """
    v = np.asarray(v, float)
    K_p = car.zeta_d * car.omega_0d * 2.0 * v / car.alpha - car.beta / car.alpha * mean_slope
    T_i = K_p * car.alpha / (car.omega_0d**2 * v)
    return K_p, T_i, car.T_a


def pid_schedule(mean_slope, car: QuarterCar) -> dict:
    """Coefficients of the speed schedule K_p = c1 v + c0, T_i = t0 + t1 / v, paper (28)-(29)."""
    c1 = 2.0 * car.zeta_d * car.omega_0d / car.alpha
    c0 = -car.beta / car.alpha * mean_slope
    return {"K_p_per_v": c1, "K_p_offset": c0, "T_i_offset": c1 * car.alpha / car.omega_0d**2, "T_i_per_inv_v": c0 * car.alpha / car.omega_0d**2}


def damping(slope, v, K_p, T_i, car: QuarterCar):
    """Relative damping and bandwidth of the closed loop (21) for a friction slope Gamma.

    zeta = (beta Gamma / (2 v) + K_p alpha / (2 v)) sqrt(T_i v / (K_p alpha)),
    omega_0 = sqrt(K_p alpha / (T_i v)).
    """
    omega_0 = np.sqrt(K_p * car.alpha / (T_i * v))
    zeta = (car.beta * np.asarray(slope, float) / (2 * v) + K_p * car.alpha / (2 * v)) / omega_0
    return zeta, omega_0


def damping_bounds(mean_slope, slope_std, v, K_p, T_i, car: QuarterCar):
    """zeta+ and zeta-, paper (24)-(25): the damping at E(Gamma) +- 2 sigma(Gamma)."""
    upper, _ = damping(mean_slope + 2 * slope_std, v, K_p, T_i, car)
    lower, _ = damping(mean_slope - 2 * slope_std, v, K_p, T_i, car)
    return upper, lower


def closed_loop_poles(zeta, omega_0):
    """Roots of s^2 + 2 zeta omega_0 s + omega_0^2, the denominator of (21); shape (..., 2)."""
    zeta = np.asarray(zeta, complex)
    root = np.sqrt(zeta**2 - 1.0)
    return np.stack([omega_0 * (-zeta + root), omega_0 * (-zeta - root)], axis=-1)


def simulate_closed_loop(mu_of_slip, car: QuarterCar, K_p_fn, T_i_fn, v0: float, lambda0: float, t_end: float, step: float, filter_ratio: float = 10.0):
    """Braking of the non-linear quarter car (11)-(12) with actuator (14) under the PID (19).

    The PID is the series form K_p (1 + T_i s)(1 + T_d s) / (T_i s) with T_d = T_a, made proper
    by a derivative filter 1 / (1 + T_a s / filter_ratio); gains are scheduled with the current
    speed. Vectorised over n friction curves; classical RK4 with a fixed step.

    Parameters
    ----------
    mu_of_slip : callable
        ``mu_of_slip(lam)`` with lam of shape (n,) returns the friction of each curve, shape (n,).
    K_p_fn, T_i_fn : callable
        Speed schedules v -> K_p, T_i.
    v0 : float
        Initial speed (m/s). lambda0 : initial slip (-). t_end, step : horizon and step (s).

    Returns
    -------
    t : ndarray, shape (K + 1,)
    states : ndarray, shape (K + 1, 5, n)
        [v, lambda, T_b, controller integral, derivative-filter state].
    """
    T_f = car.T_a / filter_ratio
    n = np.shape(mu_of_slip(np.full(1, lambda0)))[0]

    def rhs(x):
        v, lam, T_b, integ, filt = x
        lam_c = np.clip(lam, 0.0, 1.0)
        mu = mu_of_slip(lam_c)
        K_p, T_i = K_p_fn(v), T_i_fn(v)
        e = car.lambda_star - lam
        w = K_p * (e + integ / T_i)  # PI part K_p (1 + T_i s) / (T_i s)
        u = (car.T_a / T_f) * w + (1.0 - car.T_a / T_f) * filt  # lead (1 + T_d s)/(1 + T_f s)
        lam_dot = (-(1.0 / car.mass * (1.0 - lam_c) + car.r**2 / car.J) * car.F_z * mu + car.r / car.J * T_b) / v  # (11)
        v_dot = -car.F_z * mu / car.mass  # (12)
        T_b_dot = (u - T_b) / car.T_a  # (14)
        return np.stack([v_dot, lam_dot, T_b_dot, e, (w - filt) / T_f])

    K = int(round(t_end / step))
    x = np.zeros((5, n))
    x[0], x[1] = v0, lambda0
    # Start in equilibrium of the actuator and filter at the torque that holds lambda0 on average.
    x[2] = car.beta / car.alpha * mu_of_slip(np.full(n, lambda0))
    x[3] = x[2] / K_p_fn(v0) * T_i_fn(v0)
    x[4] = K_p_fn(v0) * ((car.lambda_star - lambda0) + x[3] / T_i_fn(v0))
    out = np.empty((K + 1, 5, n))
    out[0] = x
    for i in range(K):
        k1 = rhs(x)
        k2 = rhs(x + 0.5 * step * k1)
        k3 = rhs(x + 0.5 * step * k2)
        k4 = rhs(x + step * k3)
        x = x + step / 6.0 * (k1 + 2 * (k2 + k3) + k4)
        out[i + 1] = x
    return np.arange(K + 1) * step, out

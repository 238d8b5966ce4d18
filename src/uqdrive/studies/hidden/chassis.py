"""Chassis physics of the hidden-effect benchmark's reality: wheel loads from the body's
accelerations, each wheel's load-sensitive peak, the steering's compliance, the tyres' relaxation.

Written apart from the candidates of :mod:`uqdrive.vehicle.effects` (simulated by
:mod:`uqdrive.vehicle.track_extended`), whose equations they test:

- loads come from the forces the tyres actually carry (the roll and pitch moments of the ground
  forces about the centre of gravity), not from the steady accelerations v psi_dot; the algebraic
  loop between loads and forces is solved by fixed-point iteration;
- compliance steer is driven by the front axle's lateral force (a steering system yields to the
  force on its tyres), scaled so that at steady cornering it is K per g of lateral acceleration;
- relaxation lags each axle's slip angle with the wheel's own rolling speed;
- roll steer turns the front wheels with the body's roll angle, a second-order mode driven by the
  roll moment of the tyres' forces (not a first-order lag of the lateral acceleration).

Each wheel's tyre (Pacejka, *Tyre and Vehicle Dynamics*, 3rd ed., eq. (4.E13)) has the peak
D_w = mu F_zw (1 + p_Dz (F_zw - F_z0) / F_z0), F_z0 its static load, and the stiffness and shape
factors of its axle, so that its slope at zero slip is B C D_w: the linear tyre of the
single-track model is this slope, and its cornering stiffness follows the wheel's peak (a linear
tyre with load sensitivity, as the candidate ``lateral_load_transfer`` models it).
"""

from __future__ import annotations

import numpy as np

__all__ = ["FIXED_POINT_ITERATIONS", "ROLL_DAMPING", "ROLL_INERTIA", "ROLL_SHARE_FRONT", "ROLL_STIFFNESS", "axle_peak",
           "compliance_per_force", "longitudinal_acceleration", "relaxation_rate", "roll_acceleration", "roll_per_g",
           "wheel_load_transfer"]

#: Front axle's share chi_f of the lateral load transfer (-) in the reality's lateral_load_transfer
#: (a roll-stiffness distribution of a saloon with the stiffer front anti-roll bar).
ROLL_SHARE_FRONT = 0.55
#: The body's roll mode in the reality's roll_steer: stiffness (N m/rad), damping (N m s/rad) and
#: inertia (kg m^2) of a 1.8 t saloon (about 2.4 Hz, damping ratio 0.6; the roll lags the lateral
#: force by 2 zeta / omega ~ 80 ms).
ROLL_STIFFNESS, ROLL_DAMPING, ROLL_INERTIA = 140e3, 10.5e3, 550.0
#: Fixed-point iterations of the loads-forces loop: each contracts the error by the loop gain
#: (below 0.4 for |p_Dz| <= 0.5 and lateral accelerations below 0.9 g; 0.4^6 = 4e-3 of the correction).
FIXED_POINT_ITERATIONS = 6


def axle_peak(F_axle, dF, F_static, p_Dz, mu):
    """Sum of an axle's two wheels' peaks D_w = mu F_zw (1 + p_Dz (F_zw - F_z0) / F_z0).

    Pacejka (4.E13) per wheel, wheel loads F_axle / 2 -+ dF (a lifted wheel carries nothing and
    no wheel's peak falls below zero), F_z0 = F_static / 2.

    Parameters
    ----------
    F_axle : ndarray, shape (n,)
        Axle load (N) after the longitudinal transfer.
    dF : ndarray, shape (n,)
        Load moved from the inner to the outer wheel (N).
    F_static : ndarray, shape (n,)
        Static axle load (N), twice the wheels' nominal load F_z0.
    p_Dz : float
        Load sensitivity of the peak (-); 0: the peak proportional to the load.
    mu : ndarray, shape (n,)
        Friction coefficient (-).

    Returns
    -------
    ndarray, shape (n,)
        The axle's peak force (N).
    """
    F0 = 0.5 * F_static
    total = 0.0
    for wheel in (0.5 * F_axle - dF, 0.5 * F_axle + dF):
        w = np.maximum(wheel, 0.0)
        total = total + w * np.maximum(1.0 + p_Dz * (w - F0) / F0, 0.0)
    return mu * total


def longitudinal_acceleration(beta, lateral, v_dot=0.0):
    """Acceleration of the centre of gravity along the body's x axis (m/s^2) at the speed v(t).

    With v_x = v cos(beta), v_y = v sin(beta): a_x = v_x' - psi_dot v_y
    = v' cos(beta) - tan(beta) (a_y - v' sin(beta)), a_y = v_y' + psi_dot v_x the lateral one
    (Rajamani, *Vehicle Dynamics and Control*, eq. (2.27)); the drive force that holds the speed
    is whatever makes it so.

    Parameters
    ----------
    beta : ndarray, shape (n,)
        Side-slip angle (rad).
    lateral : ndarray, shape (n,)
        Lateral acceleration a_y (m/s^2).
    v_dot : float
        Rate of the speed (m/s^2).

    Returns
    -------
    ndarray, shape (n,)
    """
    return v_dot * np.cos(beta) - np.tan(beta) * (lateral - v_dot * np.sin(beta))


def wheel_load_transfer(F_tyres, h, t, share):
    """Load moved to an axle's outer wheel (N): the axle's share of the roll moment h F_tyres of
    the tyres' lateral forces about the centre of gravity, over the track (roll centres on the
    ground, roll inertia neglected; Gillespie, *Fundamentals of Vehicle Dynamics*, ch. 8).

    Parameters
    ----------
    F_tyres : ndarray, shape (n,)
        Sum of the tyres' lateral forces (N).
    h, t : float
        Centre-of-gravity height and track width (m).
    share : float
        The axle's share of the roll stiffness (-).

    Returns
    -------
    ndarray, shape (n,)
    """
    return share * h * F_tyres / t


def compliance_per_force(K_deg_per_g, m, l_r, L, g):
    """Front steer change per front lateral force (rad/N) of a compliance K (deg/g).

    The steering yields to the force on the front tyres; at steady cornering the front axle
    carries m a_y l_r / L, so K deg per g of lateral acceleration is K / (g m l_r / L) per newton.

    Parameters
    ----------
    K_deg_per_g : float
        Compliance steer (deg/g), positive out of the turn (understeer).
    m, l_r : ndarray, shape (n,)
        Mass (kg) and centre-of-gravity-to-rear-axle distance (m).
    L, g : float
        Wheelbase (m), gravity (m/s^2).

    Returns
    -------
    ndarray, shape (n,)
    """
    return np.deg2rad(K_deg_per_g) * L / (g * m * l_r)


def relaxation_rate(alpha, alpha_steady, u, sigma):
    """Rate of a lagged slip angle (rad/s): (alpha_ss - alpha) u / sigma, the first-order
    relaxation over the rolled distance sigma (Pacejka sec. 7.2).

    Parameters
    ----------
    alpha, alpha_steady : ndarray, shape (n,)
        Lagged and steady slip angle (rad).
    u : ndarray, shape (n,)
        The wheel's forward speed in its own plane (m/s).
    sigma : float
        Relaxation length (m).

    Returns
    -------
    ndarray, shape (n,)
    """
    return (alpha_steady - alpha) * u / sigma


def roll_per_g(m, h, g):
    """Steady roll angle (rad) per g of lateral acceleration: m h g / (K_phi - m g h) (Gillespie,
    ch. 8: the roll springs against the roll moment, the centre of gravity's shift adding to it).

    Parameters
    ----------
    m : ndarray, shape (n,) or float
        Mass (kg).
    h, g : float
        Centre-of-gravity height above the roll axis (m, roll centres on the ground) and gravity (m/s^2).

    Returns
    -------
    ndarray, shape (n,) or float
    """
    return m * h * g / (ROLL_STIFFNESS - m * g * h)


def roll_acceleration(phi, phi_dot, F_tyres, m, h, g):
    """Roll acceleration (rad/s^2) of the body: I_x phi'' = h F_tyres + m g h phi - K_phi phi - c_phi phi'
    (roll about the ground; positive phi: rolled out of a turn to positive y).

    Parameters
    ----------
    phi, phi_dot : ndarray, shape (n,)
        Roll angle (rad) and rate (rad/s).
    F_tyres : ndarray, shape (n,)
        Sum of the tyres' lateral forces (N).
    m : ndarray, shape (n,)
        Mass (kg).
    h, g : float
        Centre-of-gravity height (m), gravity (m/s^2).

    Returns
    -------
    ndarray, shape (n,)
    """
    return (h * F_tyres + (m * g * h - ROLL_STIFFNESS) * phi - ROLL_DAMPING * phi_dot) / ROLL_INERTIA

"""Load-dependent Magic-Formula tyre of the four-wheel reality (:mod:`uqdrive.vehicle.four_wheel.model`),
written apart from the single-track model's tyre.

Per wheel, with the normalised load increment dfz = (F_z - F_z0) / F_z0 (Pacejka, *Tyre and
Vehicle Dynamics*, 3rd ed., eq. (4.E2a)):

- peak factor D = mu F_z (1 + p_Dz dfz) (cf. Pacejka's (4.E13) with PDY1 = mu, PDY2 = p_Dz);
- cornering stiffness K_y = K_y0 sin(2 atan(F_z / (q F_z0))) / sin(2 atan(1 / q)), degressive in
  F_z and equal to K_y0 at the nominal load (the shape of Pacejka's (4.E25) with PKY2 = q);
- B = K_y / (C D), and F_y = D sin(C atan(B a - E (B a - atan(B a)))) (4.E19), without shifts;
- combined with a longitudinal force F_x by the friction ellipse: the lateral force is scaled by
  sqrt(1 - (F_x / D)^2) (Milliken & Milliken, *Race Car Vehicle Dynamics*, sec. 2.5), |F_x| < D.
"""

from __future__ import annotations

import numpy as np

__all__ = ["peak_force", "cornering_stiffness", "lateral_force", "friction_ellipse"]


def peak_force(F_z, F_z0, mu, p_Dz):
    """Peak lateral force D = mu F_z (1 + p_Dz (F_z - F_z0) / F_z0) (N), Pacejka (4.E13).

    Parameters
    ----------
    F_z : ndarray, shape (4, n)
        Wheel loads (N), clipped at 0 by the caller (a lifted wheel has no force).
    F_z0 : ndarray, shape (4, n) or (4, 1)
        Nominal (static) wheel loads (N).
    mu : ndarray, shape (n,)
        Friction coefficient (-).
    p_Dz : float
        Load sensitivity of the peak (-); negative: the peak per unit load falls with load.
    """
    return mu * F_z * (1.0 + p_Dz * (F_z - F_z0) / F_z0)


def cornering_stiffness(F_z, F_z0, K_y0, q):
    """Cornering stiffness K_y (N/rad), degressive in the load, K_y(F_z0) = K_y0.

    K_y = K_y0 sin(2 atan(F_z / (q F_z0))) / sin(2 atan(1 / q)); its maximum lies at F_z = q F_z0
    (shape of Pacejka's (4.E25)). ``F_z``, ``F_z0``, ``K_y0`` broadcast; ``q`` > 1 (-).
    """
    return K_y0 * np.sin(2.0 * np.arctan(F_z / (q * F_z0))) / np.sin(2.0 * np.arctan(1.0 / q))


def lateral_force(alpha, D, K_y, C, E):
    """Magic-Formula lateral force F_y (N) of slip angle ``alpha`` (rad), Pacejka (4.E19).

    B = K_y / (C D); where D = 0 (a lifted wheel) the force is 0.
    """
    safe = np.where(D > 0.0, D, 1.0)
    Ba = K_y / (C * safe) * alpha
    return np.where(D > 0.0, safe * np.sin(C * np.arctan(Ba - E * (Ba - np.arctan(Ba)))), 0.0)


def friction_ellipse(F_x, D):
    """Longitudinal force limited to 0.99 D and the factor sqrt(1 - (F_x / D)^2) on the lateral
    force (Milliken & Milliken sec. 2.5); ``F_x`` and ``D`` (N) broadcast."""
    limit = 0.99 * np.maximum(D, 0.0)
    F_x = np.clip(F_x, -limit, limit)
    ratio = np.where(D > 0.0, F_x / np.where(D > 0.0, D, 1.0), 0.0)
    return F_x, np.sqrt(1.0 - ratio**2)

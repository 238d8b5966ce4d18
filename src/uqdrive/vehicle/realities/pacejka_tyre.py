"""The Magic-Formula tyre of the Pacejka single-track reality: load-dependent peak and cornering
stiffness, longitudinal slip, and the combined-slip weighting functions, written apart from the models.

Per axle, with dfz = (F_z - F_z0) / F_z0 (Pacejka, *Tyre and Vehicle Dynamics*, 3rd ed.):

- peak D = mu F_z (1 + p_Dz dfz) (4.E13), the same for both directions;
- cornering stiffness K_y = K_y0 sin(2 atan(F_z / (q F_z0))) / sin(2 atan(1 / q)) (the shape of
  (4.E25)), slip stiffness K_x = k_x F_z (4.E15 without its load dependence);
- pure slip F_y0 = D sin(C atan(B a - E (B a - atan(B a)))), B = K_y / (C D) (4.E19), and
  F_x0 = D sin(C_x atan(B_x kappa)), B_x = K_x / (C_x D);
- combined slip by the cosine weighting functions (4.E50)-(4.E57) without shifts:
  F_x = F_x0 cos(atan(B_xa a)), B_xa = r_Bx1 cos(atan(r_Bx2 kappa)) and
  F_y = F_y0 cos(atan(B_yk kappa)), B_yk = r_By1 cos(atan(r_By2 a)).
"""

from __future__ import annotations

import numpy as np

__all__ = ["peak", "cornering_stiffness", "pure_lateral", "pure_longitudinal", "combined"]


def peak(F_z, F_z0, mu, p_Dz):
    """D = mu F_z (1 + p_Dz (F_z - F_z0) / F_z0) (N) of loads ``F_z`` (N, any shape) against the
    nominal loads ``F_z0`` (N, broadcasting); at least 0."""
    return np.maximum(mu * F_z * (1.0 + p_Dz * (F_z - F_z0) / F_z0), 0.0)


def cornering_stiffness(F_z, F_z0, K_y0, q):
    """K_y (N/rad), degressive in the load ``F_z`` (N), K_y0 at ``F_z0`` and largest at q F_z0."""
    return K_y0 * np.sin(2.0 * np.arctan(np.maximum(F_z, 0.0) / (q * F_z0))) / np.sin(2.0 * np.arctan(1.0 / q))


def pure_lateral(alpha, D, K_y, C, E):
    """Lateral force F_y0 (N) at slip angle ``alpha`` (rad) with peak ``D`` and stiffness ``K_y``."""
    safe = np.where(D > 0.0, D, 1.0)
    x = K_y / (C * safe) * alpha
    return np.where(D > 0.0, safe * np.sin(C * np.arctan(x - E * (x - np.arctan(x)))), 0.0)


def pure_longitudinal(kappa, D, K_x, C_x):
    """Longitudinal force F_x0 (N) at slip ratio ``kappa`` (-) with peak ``D`` and slip stiffness ``K_x``."""
    safe = np.where(D > 0.0, D, 1.0)
    return np.where(D > 0.0, safe * np.sin(C_x * np.arctan(K_x / (C_x * safe) * kappa)), 0.0)


def combined(F_x0, F_y0, kappa, alpha, r_Bx=(12.0, 10.0), r_By=(7.0, 2.5)):
    """Forces (F_x, F_y) (N) of the pure-slip forces at slip ``kappa`` and ``alpha`` weighted by
    cos(atan(B kappa)) and cos(atan(B alpha)) (Pacejka (4.E51), (4.E59) with C = 1, no shifts)."""
    B_xa = r_Bx[0] * np.cos(np.arctan(r_Bx[1] * kappa))
    B_yk = r_By[0] * np.cos(np.arctan(r_By[1] * alpha))
    return F_x0 * np.cos(np.arctan(B_xa * alpha)), F_y0 * np.cos(np.arctan(B_yk * kappa))

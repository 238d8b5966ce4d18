"""The generic catch-all: a smooth additive discrepancy on every statistic trajectory (a cubic
B-spline per signal and statistic), fitted in z units by linear least squares. When it fits far
better than every named effect, the gap is real but unnamed: ``unrecognised``.
"""

from __future__ import annotations

import numpy as np
from scipy.interpolate import BSpline

__all__ = ["spline_basis", "smooth_discrepancy"]


def spline_basis(K: int, n_basis: int = 8, degree: int = 3):
    """Clamped cubic B-spline basis on K equally spaced points, shape (K, n_basis)."""
    n_basis = max(degree + 1, min(int(n_basis), K))
    inner = np.linspace(0.0, 1.0, n_basis - degree + 1)
    knots = np.concatenate([np.zeros(degree), inner, np.ones(degree)])
    x = np.linspace(0.0, 1.0, K)
    basis = BSpline(knots, np.eye(n_basis), degree)(x)
    return np.nan_to_num(basis)


def smooth_discrepancy(z, n_basis: int = 8):
    """Remove the best smooth additive discrepancy from every row of z.

    Parameters
    ----------
    z : ndarray, shape (2, 4, K)
        Standardised gap of the baseline.
    n_basis : int
        Spline functions per row.

    Returns
    -------
    residual : ndarray, shape (2, 4, K)
        z minus its least-squares spline fit, row by row.
    n_parameters : int
        Number of fitted coefficients (8 rows x n_basis).
    """
    z = np.asarray(z, float)
    K = z.shape[-1]
    S = spline_basis(K, n_basis)
    rows = z.reshape(-1, K)
    coef, *_ = np.linalg.lstsq(S, rows.T, rcond=None)
    residual = rows - (S @ coef).T
    return residual.reshape(z.shape), int(rows.shape[0] * S.shape[1])

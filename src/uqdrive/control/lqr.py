"""Controllers on the single-track model: the LQR of the mean LST (thesis 6.1).

The stochastic LQR on the PCE system (thesis 4.66, 5.35-5.38) builds on this module.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import solve_continuous_are

__all__ = ["lqr_gain"]


def lqr_gain(A, B, Q, R):
    """Continuous infinite-horizon LQR gain for the feedback u = K x (thesis sign convention).

    Parameters
    ----------
    A : ndarray, shape (d, d)
    B : ndarray, shape (d,) or (d, m)
    Q : ndarray, shape (d, d)
    R : float or ndarray, shape (m, m)

    Returns
    -------
    K : ndarray, shape (m, d)
        K = -R^-1 B^T P with P the stabilising solution of the Riccati equation.
    """
    A = np.asarray(A, float)
    B = np.asarray(B, float).reshape(A.shape[0], -1)
    R = np.atleast_2d(np.asarray(R, float))
    P = solve_continuous_are(A, B, np.asarray(Q, float), R)
    return -np.linalg.solve(R, B.T @ P)

"""Matrix exponentials of many small matrices at once, and Frechet derivatives of one in many
directions at once: scaling and squaring with a Taylor polynomial, vectorised over the stack.
"""

from __future__ import annotations

import numpy as np

__all__ = ["batched_expm", "expm_frechet_directions"]

_TAYLOR_DEGREE = 12


def batched_expm(M):
    """Matrix exponential of a stack of small matrices, vectorised over the stack.

    Scaling and squaring with a degree-12 Taylor polynomial: each matrix is scaled by 2^-s so
    that its 1-norm is at most 1/4, where the truncation error (1/4)^13 / 13! ~ 2e-18 is below
    double precision, then squared s times. ``scipy.linalg.expm`` gives the same result but
    loops over the stack in Python, which costs ten times more for thousands of 12x12 blocks.

    Parameters
    ----------
    M : ndarray, shape (..., d, d)

    Returns
    -------
    ndarray, shape (..., d, d)
    """
    M = np.asarray(M, float)
    norm = np.abs(M).sum(axis=-2).max(axis=-1).max() if M.size else 0.0
    s = max(0, int(np.ceil(np.log2(norm / 0.25)))) if norm > 0.25 else 0
    X = M / 2.0**s
    eye = np.broadcast_to(np.eye(M.shape[-1]), M.shape)
    F = eye + X / _TAYLOR_DEGREE
    for k in range(_TAYLOR_DEGREE - 1, 0, -1):  # Horner: I + X/1 (I + X/2 (I + ...))
        F = eye + (X @ F) / k
    for _ in range(s):
        F = F @ F
    return F


def expm_frechet_directions(M, directions):
    """Frechet derivatives L(M, D_p) of the matrix exponential in several directions at once.

    The degree-12 Taylor polynomial of :func:`batched_expm` after scaling by 2^-s, differentiated
    term by term (Horner: F <- I + X F / k, dF <- (D F + X dF) / k) and through the s squarings
    (dF <- dF F + F dF), for all directions in the same batched products: one call instead of one
    ``scipy.linalg.expm_frechet`` per direction, each of which recomputes the Pade terms of M.

    Parameters
    ----------
    M : ndarray, shape (n, n)
    directions : ndarray, shape (p, n, n)

    Returns
    -------
    ndarray, shape (p, n, n)
    """
    M = np.asarray(M, float)
    norm = np.abs(M).sum(axis=0).max() if M.size else 0.0
    s = max(0, int(np.ceil(np.log2(norm / 0.25)))) if norm > 0.25 else 0
    X, dX = M / 2.0**s, np.asarray(directions, float) / 2.0**s
    eye = np.eye(M.shape[0])
    F = eye + X / _TAYLOR_DEGREE
    dF = dX / _TAYLOR_DEGREE
    for k in range(_TAYLOR_DEGREE - 1, 0, -1):
        dF = (dX @ F + X @ dF) / k
        F = eye + (X @ F) / k
    for _ in range(s):
        dF = dF @ F + F @ dF
        F = F @ F
    return dF

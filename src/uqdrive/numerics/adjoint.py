"""Reverse-mode (adjoint) derivatives of an exactly discretised LTI response: one backward
recursion and one adjoint Frechet derivative give the gradient of any scalar of the trajectory.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import expm_frechet

from .recursion import reverse_linear_recursion

__all__ = ["backward_recursion", "foh_response_vjp"]


def backward_recursion(Phi, G):
    """Adjoint states of x_{k+1} = Phi x_k + drive_k for the cotangents G_k = dJ/dx_k (direct).

    lambda_K = G_K and lambda_k = G_k + Phi^T lambda_{k+1}: lambda_k is the total derivative of J
    with respect to x_k.

    Parameters
    ----------
    Phi : ndarray, shape (N, N)
    G : ndarray, shape (K + 1, N)

    Returns
    -------
    ndarray, shape (K + 1, N)
    """
    return reverse_linear_recursion(Phi, G)


def _van_loan_input_block(A, E, h):
    """Van Loan's block [[A, E, 0], [0, 0, I], [0, 0, 0]] h of one system (size d + 2r): its
    exponential holds Phi, J_0 E and J_1 E, and its Frechet derivative those maps' derivatives."""
    d, r = E.shape
    M = np.zeros((d + 2 * r, d + 2 * r))
    M[:d, :d] = A * h
    M[:d, d : d + r] = E * h
    M[d : d + r, d + r :] = np.eye(r) * h
    return M


def foh_response_vjp(A, E, h: float, Phi, g, X, G):
    """Gradient of a scalar J of the response with respect to the continuous A and E.

    The response is x_{k+1} = Phi x_k + P g_k + Q g_{k+1} with the first-order-hold maps of
    :func:`uqdrive.numerics.integrate.foh_discretise_single` (the top row of Van Loan's block
    exponential F = exp(M)).
    With the adjoint states lambda, dJ/dPhi = sum_k lambda_{k+1} x_k^T, dJ/dP = sum_k
    lambda_{k+1} g_k^T and dJ/dQ = sum_k lambda_{k+1} g_{k+1}^T; these give the cotangent W of F,
    and the adjoint of the Frechet derivative, <W, L(M, D)> = <L(M^T, W), D>, gives dJ/dM in one
    ``expm_frechet`` call, whatever the number of parameters. x_0 is taken as fixed.

    Parameters
    ----------
    A : ndarray, shape (N, N)
    E : ndarray, shape (N, r)
    h : float
        Step (s).
    Phi : ndarray, shape (N, N)
        exp(A h), as used by the forward recursion.
    g : ndarray, shape (K + 1, r)
        Inputs on the grid.
    X : ndarray, shape (K + 1, N)
        Forward trajectory.
    G : ndarray, shape (K + 1, N)
        dJ/dx_k, the direct cotangents of the trajectory.

    Returns
    -------
    dJ_dA : ndarray, shape (N, N)
    dJ_dE : ndarray, shape (N, r)
    """
    d, r = np.shape(E)
    lam = backward_recursion(Phi, G)[1:]
    g = np.asarray(g, float)
    dPhi, dP, dQ = lam.T @ X[:-1], lam.T @ g[:-1], lam.T @ g[1:]
    M = _van_loan_input_block(A, E, h)
    W = np.zeros_like(M)
    W[:d, :d] = dPhi
    W[:d, d : d + r] = dP  # P = F_2 - F_3 / h and Q = F_3 / h
    W[:d, d + r :] = (dQ - dP) / h
    _, dM = expm_frechet(M.T, W)
    return h * dM[:d, :d], h * dM[:d, d : d + r]

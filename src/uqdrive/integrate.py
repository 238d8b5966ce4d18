"""Time integration kernels for ensembles: exact first-order-hold discretisation of batched LTI
systems, and a fixed-step classical Runge-Kutta scheme vectorised over realisations.
"""

from __future__ import annotations

from typing import Callable

import numpy as np
from scipy.linalg import expm

__all__ = ["foh_discretise", "lti_foh_response", "rk4_fixed_step"]


def foh_discretise(A, E, h: float):
    """Exact discretisation of x' = A x + E g(t) for g linear between samples (first-order hold).

    Uses Van Loan's block exponential exp([[A, E, 0], [0, 0, I], [0, 0, 0]] h), whose top row is
    [Phi, Gamma_0, Gamma_1] with Gamma_0 = int_0^h e^{A s} E ds and
    Gamma_1 = int_0^h e^{A s} E (h - s) ds; then
    x_{k+1} = Phi x_k + P g_k + Q g_{k+1} with Q = Gamma_1 / h and P = Gamma_0 - Q.

    Parameters
    ----------
    A : ndarray, shape (..., d, d)
    E : ndarray, shape (..., d, r)
    h : float
        Step (s).

    Returns
    -------
    Phi : ndarray, shape (..., d, d)
    P, Q : ndarray, shape (..., d, r)
    """
    A = np.asarray(A, float)
    E = np.asarray(E, float)
    d, r = E.shape[-2], E.shape[-1]
    M = np.zeros(A.shape[:-2] + (d + 2 * r, d + 2 * r))
    M[..., :d, :d] = A
    M[..., :d, d : d + r] = E
    M[..., d : d + r, d + r :] = np.eye(r)
    F = expm(M * h)
    Phi = F[..., :d, :d]
    Gamma0 = F[..., :d, d : d + r]
    Q = F[..., :d, d + r :] / h
    return Phi, Gamma0 - Q, Q


def lti_foh_response(A, E, g, h: float, substeps: int, x0=None):
    """Response of a batch of LTI systems to shared input signals, exact for piecewise-linear g.

    The state is only advanced on the output grid (every ``substeps`` fine steps): the fine
    first-order-hold maps are folded into one state transition and one input matrix per output
    step, so the Python loop runs once per output sample and the input drive of all output
    steps is a single matrix product.

    Parameters
    ----------
    A : ndarray, shape (n, d, d)
        State matrices of n systems.
    E : ndarray, shape (n, d, r)
        Input matrices; system j sees E[j] g(t).
    g : ndarray, shape (K * substeps + 1, r)
        Input signals on the fine grid t_i = i h, shared by all systems.
    h : float
        Fine step (s).
    substeps : int
        Fine steps per output step.
    x0 : ndarray, shape (n, d), optional
        Initial state (zero by default).

    Returns
    -------
    ndarray, shape (K + 1, n, d)
        States on the output grid t_k = k * substeps * h.
    """
    A = np.asarray(A, float)
    E = np.asarray(E, float)
    g = np.asarray(g, float)
    n, d, r = E.shape
    S = int(substeps)
    if (g.shape[0] - 1) % S:
        raise ValueError("g must hold K * substeps + 1 samples")
    K = (g.shape[0] - 1) // S
    Phi, P, Q = foh_discretise(A, E, h)
    # M[s] maps the fine sample s of one output interval to the state at its end.
    M = np.zeros((S + 1, n, d, r))
    power = np.broadcast_to(np.eye(d), (n, d, d)).copy()  # Phi^(S-1-s), built from s = S-1 down
    for s in range(S - 1, -1, -1):
        M[s] += power @ P
        M[s + 1] += power @ Q
        power = power @ Phi
    Phi_out = power  # Phi^S
    windows = np.lib.stride_tricks.sliding_window_view(g, (S + 1, r))[::S, 0]  # (K, S+1, r)
    drive = np.einsum("snir,ksr->kni", M, windows, optimize=True)  # (K, n, d)
    x = np.zeros((K + 1, n, d))
    if x0 is not None:
        x[0] = x0
    for k in range(K):
        x[k + 1] = np.einsum("nij,nj->ni", Phi_out, x[k]) + drive[k]
    return x


def rk4_fixed_step(rhs: Callable[[np.ndarray, int], np.ndarray], x0, h: float, n_steps: int, record_every: int):
    """Classical fourth-order Runge-Kutta with a fixed step, vectorised over realisations.

    Parameters
    ----------
    rhs : callable
        ``rhs(x, j)`` returns dx/dt at time j * h / 2 for the state ``x`` of shape (d, n); the
        half-step index ``j`` lets the caller read inputs precomputed on the half-step grid.
    x0 : ndarray, shape (d, n)
    h : float
        Step (s).
    n_steps : int
        Number of steps; must be a multiple of ``record_every``.
    record_every : int
        Store the state every this many steps.

    Returns
    -------
    ndarray, shape (n_steps // record_every + 1, d, n)
    """
    if n_steps % record_every:
        raise ValueError("n_steps must be a multiple of record_every")
    x = np.array(x0, dtype=float)
    out = np.empty((n_steps // record_every + 1,) + x.shape)
    out[0] = x
    half = 0.5 * h
    for i in range(n_steps):
        j = 2 * i
        k1 = rhs(x, j)
        k2 = rhs(x + half * k1, j + 1)
        k3 = rhs(x + half * k2, j + 1)
        k4 = rhs(x + h * k3, j + 2)
        x = x + (h / 6.0) * (k1 + 2.0 * (k2 + k3) + k4)
        if (i + 1) % record_every == 0:
            out[(i + 1) // record_every] = x
    return out

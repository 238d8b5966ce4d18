"""Time integration kernels: responses of exactly discretised LTI systems (batched small ones, or
one large one by its decoupled blocks, with exact parameter derivatives) and a vectorised RK4.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from .discretise import foh_discretise, foh_discretise_derivatives
from .recursion import consecutive_slice, decoupled_blocks, identical_block_groups, linear_recursion_in_place

__all__ = [
    "cumulative_trapezoid",
    "decoupled_blocks",
    "foh_discretise",
    "foh_discretise_derivatives",
    "foh_discretise_single",
    "lti_foh_response",
    "lti_response_single",
    "rk4_fixed_step",
    "rk4_fixed_step_into",
    "rk4_stage",
    "rk4_advance",
]


def foh_discretise_single(A, E, h: float, dA=None, dE=None):
    """First-order-hold discretisation of one (large) system, optionally with exact derivatives.

    Same maps as :func:`foh_discretise` (x_{k+1} = Phi x_k + P g_k + Q g_{k+1}); with directions
    ``dA``, ``dE`` also the exact derivatives of Phi, P and Q, i.e. of the discretised system,
    carried through the series and the doublings (:func:`foh_discretise_derivatives`).

    Decoupled blocks of A (e.g. the Galerkin terms of each KLE germ of the wind, which never mix
    with the others) are discretised one at a time with only the inputs that reach them: the
    result is the same, and the exponentials are of the blocks' size, not the system's.

    Parameters
    ----------
    A : ndarray, shape (N, N)
    E : ndarray, shape (N, r)
    h : float
    dA : ndarray, shape (p, N, N), optional
    dE : ndarray, shape (p, N, r), optional

    Returns
    -------
    (Phi, P, Q), and if derivatives were asked for also (dPhi, dP, dQ) with a leading axis p.
    """
    A = np.asarray(A, float)
    E = np.asarray(E, float)
    d, r = E.shape
    pattern = A != 0
    reach = E != 0
    if dA is not None:
        dA, dE = np.asarray(dA, float), np.asarray(dE, float)
        pattern = pattern | np.any(dA != 0, axis=0)
        reach = reach | np.any(dE != 0, axis=0)
    blocks = decoupled_blocks(pattern)
    if len(blocks) == 1:
        return _foh_block(A, E, h, dA, dE)
    Phi, P, Q = np.zeros((d, d)), np.zeros((d, r)), np.zeros((d, r))
    if dA is None:
        # Blocks with identical matrices (the KLE germs' blocks) share one exponential: their
        # inputs become extra columns of the same Van Loan block.
        for group in identical_block_groups(A):
            members = [(_ix(idx, idx), _ix(idx, np.flatnonzero(np.any(reach[idx], axis=0)))) for idx in group]
            E_group = np.concatenate([E[rect] for _, rect in members], axis=1)
            Phi_b, P_b, Q_b = _foh_block(A[members[0][0]], E_group, h)
            start = 0
            for square, rect in members:
                Phi[square] = Phi_b
                stop = start + E[rect].shape[1]
                P[rect], Q[rect] = P_b[:, start:stop], Q_b[:, start:stop]
                start = stop
        return Phi, P, Q
    n_p = dA.shape[0]
    dPhi, dP, dQ = np.zeros((n_p, d, d)), np.zeros((n_p, d, r)), np.zeros((n_p, d, r))
    for idx in blocks:
        cols = np.flatnonzero(np.any(reach[idx], axis=0))
        sq, rect = _ix(idx, idx), _ix(idx, cols)
        (Phi[sq], P[rect], Q[rect]), (b_dPhi, b_dP, b_dQ) = _foh_block(A[sq], E[rect], h, dA[(slice(None),) + sq], dE[(slice(None),) + rect])
        dPhi[(slice(None),) + sq] = b_dPhi
        dP[(slice(None),) + rect] = b_dP
        dQ[(slice(None),) + rect] = b_dQ
    return (Phi, P, Q), (dPhi, dP, dQ)


def _ix(rows, cols):
    """``np.ix_(rows, cols)``, with slices for runs of consecutive indices (the block-ordered
    layouts): basic indexing, far cheaper than fancy indexing."""
    row_run, col_run = consecutive_slice(rows), consecutive_slice(cols)
    if row_run is None:
        return np.ix_(rows, cols)
    return row_run, cols if col_run is None else col_run


def _foh_block(A, E, h, dA=None, dE=None):
    """:func:`foh_discretise_single` for one coupled block (:func:`foh_discretise_derivatives`)."""
    if dA is None:
        return foh_discretise(A, E, h)
    return foh_discretise_derivatives(A, E, h, dA, dE)


def lti_response_single(Phi, P, Q, g, x0, derivatives=None, dx0=None):
    """Response of one discretised system to sampled inputs, optionally with its sensitivities.

    x_{k+1} = Phi x_k + P g_k + Q g_{k+1}; the sensitivity s_p = dx/dtheta_p obeys
    s_{p,k+1} = Phi s_{p,k} + dPhi_p x_k + dP_p g_k + dQ_p g_{k+1}, the exact derivative of the
    discretised recursion. Both recursions run by chunks of steps over Phi's decoupled blocks
    (:func:`uqdrive.recursion.linear_recursion`), not one Python step per sample.

    Parameters
    ----------
    Phi : ndarray, shape (N, N)
    P, Q : ndarray, shape (N, r)
    g : ndarray, shape (K + 1, r)
        Inputs on the output grid.
    x0 : ndarray, shape (N,)
    derivatives : tuple (dPhi, dP, dQ) with leading axis p, optional
    dx0 : ndarray, shape (p, N), optional

    Returns
    -------
    x : ndarray, shape (K + 1, N)
    s : ndarray, shape (K + 1, p, N), only with ``derivatives``
    """
    g = np.asarray(g, float)
    K, N = g.shape[0] - 1, Phi.shape[0]
    # Drives are formed straight in the output by one GEMM each: [g_k, g_{k+1}] [P Q]^T, and for
    # the sensitivities [x_k, g_k, g_{k+1}] [dPhi dP dQ]^T (the state enters through dPhi x_k).
    pairs = np.concatenate([g[:-1], g[1:]], axis=1)  # (K, 2 r)
    x = np.empty((K + 1, N))
    x[0] = x0
    np.matmul(pairs, np.concatenate([P, Q], axis=1).T, out=x[1:])
    groups = identical_block_groups(Phi)
    linear_recursion_in_place(Phi, x, groups)
    if derivatives is None:
        return x
    dPhi, dP, dQ = derivatives
    n_p = dPhi.shape[0]
    s = np.empty((K + 1, n_p, N))
    s[0] = 0.0 if dx0 is None else dx0
    maps = np.concatenate([dPhi, dP, dQ], axis=2)  # (p, N, N + 2 r)
    np.matmul(np.concatenate([x[:-1], pairs], axis=1), maps.transpose(2, 0, 1).reshape(-1, n_p * N), out=s[1:].reshape(K, n_p * N))
    return x, linear_recursion_in_place(Phi, s, groups)


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
    ndarray, shape (d, n, K + 1)
        States on the output grid t_k = k * substeps * h, state-major so that each state's
        (n, K + 1) block is contiguous.
    """
    A = np.asarray(A, float)
    E = np.asarray(E, float)
    g = np.asarray(g, float)
    n, d, r = E.shape
    S = int(substeps)
    if (g.shape[0] - 1) % S:
        raise ValueError("g must hold K * substeps + 1 samples")
    Phi, P, Q = foh_discretise(A, E, h)
    # M[s, q, i, j] maps input q at the fine sample s of one output interval to state i of
    # system j at its end. Systems last: the products of n small matrices are einsums over a
    # contiguous last axis (2-3x faster than a batched matmul of (n, d, d) stacks), and M is
    # already in the layout of the drive's BLAS product below.
    P_t, Q_t = (np.ascontiguousarray(np.moveaxis(a, 0, -1)) for a in (P, Q))  # (d, r, n)
    Phi_t = np.ascontiguousarray(np.moveaxis(Phi, 0, -1))  # (d, d, n)
    M = np.zeros((S + 1, r, d, n))
    M[S - 1] = P_t.transpose(1, 0, 2)  # Phi^0 = I for the last fine step
    M[S] = Q_t.transpose(1, 0, 2)
    power = Phi_t  # Phi^(S-1-s), built from s = S-1 down
    for s in range(S - 2, -1, -1):
        M[s] += np.einsum("ikn,kqn->qin", power, P_t)
        M[s + 1] += np.einsum("ikn,kqn->qin", power, Q_t)
        power = np.einsum("ikn,kjn->ijn", power, Phi_t)
    windows = np.lib.stride_tricks.sliding_window_view(g, (S + 1, r))[::S, 0]  # (K, S+1, r)
    # drive[k, i, j] = sum_{s, q} M[s, q, i, j] windows[k, s, q] is one BLAS product (several
    # times faster than the equivalent einsum), written straight into the output's slots.
    K = windows.shape[0]
    out = np.empty((K + 1, d, n))
    np.matmul(windows.reshape(K, -1), M.reshape((S + 1) * r, d * n), out=out[1:].reshape(K, d * n))
    out[0] = 0.0 if x0 is None else np.asarray(x0, float).T
    _linear_recursion_in_place(np.moveaxis(power, -1, 0), out)  # power = Phi^S
    return out.transpose(1, 2, 0)


def _linear_recursion_in_place(Phi, out):
    """x_{k+1} = Phi x_k + drive_k for n systems at once, where out[k + 1] holds drive_k on entry.

    One ``einsum`` over a state-major layout per step (about 7x faster than a batched
    ``matmul`` of n 4x4 matrices, which loops over the small matrices). The states are stored
    time-major, as the recursion produces them; the caller returns a transposed view, because
    copying 64 MB into a time-contiguous layout would cost as much as the recursion itself, and
    holding the drive in the output saves another 64 MB of traffic and page faults.

    Parameters
    ----------
    Phi : ndarray, shape (n, d, d)
    out : ndarray, shape (K + 1, d, n)
        out[0] = x_0 and out[k + 1] = drive_k on entry; the states x_0..x_K on return.
    """
    Phi_t = np.ascontiguousarray(np.moveaxis(Phi, 0, -1))  # (d, d, n)
    step = np.empty(out.shape[1:])
    for k in range(out.shape[0] - 1):
        np.einsum("ijn,jn->in", Phi_t, out[k], out=step)
        out[k + 1] += step


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
    # The in-place stepper's operations are these, each sum in this order (x + h/2 k1 is formed as
    # h/2 k1 + x, the same double): one extra copy of dx/dt per stage, the same numbers.
    return rk4_fixed_step_into(lambda x, j, out: np.copyto(out, rhs(x, j)), x0, h, n_steps, record_every)


def rk4_stage(k, c: float, x, xs) -> None:
    """The next stage's state ``xs`` = c k + x, in place (NumPy's two passes)."""
    np.multiply(k, c, xs)
    xs += x


def rk4_advance(x, k1, k2, k3, k4, sixth: float) -> None:
    """x += (h / 6) (k1 + 2 (k2 + k3) + k4) in place, in :func:`rk4_fixed_step`'s order (``k2`` overwritten)."""
    k2 += k3
    k2 *= 2.0
    k2 += k1
    k2 += k4
    k2 *= sixth
    x += k2


def rk4_fixed_step_into(rhs: Callable[[np.ndarray, int, np.ndarray], None], x0, h: float, n_steps: int, record_every: int,
                        stage: Callable = rk4_stage, advance: Callable = rk4_advance):
    """:func:`rk4_fixed_step` for a right-hand side that writes into a given array.

    The stages and the state are updated in place, so a step allocates nothing; for the small
    batches of a discover fit (a few hundred realisations) NumPy's per-call cost, not the
    arithmetic, is most of a step. :func:`rk4_fixed_step` is this stepper with a copying
    right-hand side.

    Parameters
    ----------
    rhs : callable
        ``rhs(x, j, out)`` writes dx/dt at time j * h / 2 for the state ``x`` (d, n) into ``out``
        (d, n); it must not keep ``x`` or ``out``.
    x0, h, n_steps, record_every
        As for :func:`rk4_fixed_step`.
    stage, advance : callable
        The array arithmetic, with the signatures and the numbers of :func:`rk4_stage` and
        :func:`rk4_advance` (:mod:`uqdrive.vehicle.dynamics.fused_rk4`: compiled loops); the
        states are C-contiguous float64.

    Returns
    -------
    ndarray, shape (n_steps // record_every + 1, d, n)
    """
    if n_steps % record_every:
        raise ValueError("n_steps must be a multiple of record_every")
    x = np.array(x0, dtype=float, order="C")
    out = np.empty((n_steps // record_every + 1,) + x.shape)
    out[0] = x
    half, sixth = 0.5 * h, h / 6.0
    k1, k2, k3, k4, xs = (np.empty_like(x) for _ in range(5))
    for i in range(n_steps):
        j = 2 * i
        rhs(x, j, k1)
        stage(k1, half, x, xs)
        rhs(xs, j + 1, k2)
        stage(k2, half, x, xs)
        rhs(xs, j + 1, k3)
        stage(k3, h, x, xs)
        rhs(xs, j + 2, k4)
        advance(x, k1, k2, k3, k4, sixth)
        if (i + 1) % record_every == 0:
            out[(i + 1) // record_every] = x
    return out


def cumulative_trapezoid(f, h: float):
    """Integral from 0 of samples f (..., K + 1) on a grid of step h (trapezoid), same shape.

    Parameters
    ----------
    f : ndarray, shape (..., K + 1)
        Samples on a uniform grid (any unit u).
    h : float
        Grid step (s).

    Returns
    -------
    ndarray, shape (..., K + 1)
        The integral from 0 (u s).

    It integrates v (sin c - c), c = psi + k beta, whose size is c^3 / 6: the trapezoid's error,
    h^2 / 12 of its second derivative, is ~1e-3 of the term itself on a 4 s slalom at h = 0.07 s.
    """
    out = np.zeros_like(f)
    np.cumsum(0.5 * h * (f[..., 1:] + f[..., :-1]), axis=-1, out=out[..., 1:])
    return out

"""Linear recursions x_{k+1} = Phi x_k + d_k of one discretised system over many steps, in a few
batched matrix products instead of one Python step per sample (two-level, chunked evaluation).
"""

from __future__ import annotations

import functools

import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import connected_components

__all__ = ["decoupled_blocks", "identical_block_groups", "linear_recursion", "reverse_linear_recursion"]


def decoupled_blocks(pattern) -> list[np.ndarray]:
    """Index sets of the decoupled blocks of a square sparsity pattern (connected components).

    Parameters
    ----------
    pattern : ndarray of bool, shape (N, N)

    Returns
    -------
    list of ndarray of int (read-only)
    """
    pattern = np.asarray(pattern, bool)
    symmetric = pattern | pattern.T
    # A model's pattern is the same at every parameter value: the graph search (scipy's sparse
    # machinery, ~0.3 ms) runs once per pattern, the lookup costs microseconds.
    return list(_components(symmetric.shape[0], np.packbits(symmetric).tobytes()))


@functools.lru_cache(maxsize=32)
def _components(n, packed: bytes) -> tuple:
    pattern = np.unpackbits(np.frombuffer(packed, np.uint8), count=n * n).reshape(n, n).astype(bool)
    count, labels = connected_components(csr_matrix(pattern), directed=False)
    blocks = tuple(np.flatnonzero(labels == c) for c in range(count))
    for b in blocks:
        b.setflags(write=False)
    return blocks


def _chunked(Phi, drive, x0):
    """:func:`linear_recursion` for one dense Phi (n, n) and drive (K, ..., n), K >= 1.

    The K steps are cut into C chunks of L ~ sqrt(K) steps. Pass 1 runs all chunks at once from
    zero to get each chunk's end state; a short sequential pass over the C chunk starts adds the
    carries with Phi^L; pass 2 runs all chunks at once again from their true starts, writing the
    states over the drive. That is 2 L + C small products instead of K, with twice the
    arithmetic of the plain loop: the same sums in another order, equal to round-off for a
    stable or marginally stable Phi (powers up to Phi^L are formed, L ~ 32).
    """
    K = drive.shape[0]
    tail = drive.shape[1:]
    n = tail[-1]
    L = max(1, int(np.sqrt(K)))
    C = -(-K // L)
    out = np.empty((C * L + 1,) + tail)
    out[0] = x0
    out[1 : K + 1] = drive
    out[K + 1 :] = 0.0
    # z[c, i] holds x_{c L + i + 1}: a view, so the states are written where they belong. Each
    # step of all chunks is one 2-D product (its rows gathered when there are batch columns).
    z = out[1:].reshape(C, L, -1, n)
    Phi_T = np.ascontiguousarray(Phi.T)
    end = z[:, 0].reshape(-1, n)
    for i in range(1, L):
        end = end @ Phi_T
        end += z[:, i].reshape(-1, n)
    end = end.reshape(C, -1, n)
    starts = np.empty_like(end)
    starts[0] = np.reshape(x0, (-1, n))
    Phi_L_T = np.linalg.matrix_power(Phi_T, L)
    for c in range(1, C):
        starts[c] = starts[c - 1] @ Phi_L_T + end[c - 1]
    state = starts.reshape(-1, n)
    for i in range(L):
        z[:, i] += (state @ Phi_T).reshape(C, -1, n)
        state = z[:, i].reshape(-1, n)
    return out[: K + 1]


def identical_block_groups(Phi) -> list[np.ndarray]:
    """Decoupled blocks of Phi, grouped when their matrices are identical.

    Parameters
    ----------
    Phi : ndarray, shape (N, N)

    Returns
    -------
    list of ndarray of int, each of shape (m, b)
        The m blocks of size b in a group (e.g. the Galerkin terms of each KLE germ, which share
        one matrix) advance together as a batch of m systems.
    """
    groups: dict = {}
    for idx in decoupled_blocks(np.asarray(Phi) != 0):
        groups.setdefault((idx.size, Phi[np.ix_(idx, idx)].tobytes()), []).append(idx)
    return [np.stack(members) for members in groups.values()]


def linear_recursion(Phi, drive, x0=None, groups=None):
    """States of x_{k+1} = Phi x_k + d_k for k = 0..K-1, vectorised over time by chunks.

    Parameters
    ----------
    Phi : ndarray, shape (N, N)
        Transition matrix of one step.
    drive : ndarray, shape (K, ..., N)
        d_k; the middle axes (e.g. parameter sensitivities) are independent right-hand sides.
    x0 : ndarray, shape (..., N), optional
        Initial state (zero by default).
    groups : list of ndarray, optional
        Block structure of Phi from :func:`identical_block_groups` (computed if omitted); each
        group of identical blocks is advanced as one batch.

    Returns
    -------
    ndarray, shape (K + 1, ..., N)
    """
    Phi = np.asarray(Phi, float)
    drive = np.asarray(drive, float)
    x0 = np.zeros(drive.shape[1:]) if x0 is None else np.broadcast_to(np.asarray(x0, float), drive.shape[1:])
    if drive.shape[0] == 0:
        return x0[None].copy()
    if groups is None:
        groups = identical_block_groups(Phi)
    if len(groups) == 1 and groups[0].shape[0] == 1:
        return _chunked(Phi, drive, x0)
    out = np.empty((drive.shape[0] + 1,) + drive.shape[1:])
    for idx in groups:
        first = idx[0]
        out[..., idx] = _chunked(Phi[np.ix_(first, first)], drive[..., idx], x0[..., idx])
    return out


def reverse_linear_recursion(Phi, G, groups=None):
    """Adjoint states lambda_K = G_K, lambda_k = G_k + Phi^T lambda_{k+1} (backward in time).

    Parameters
    ----------
    Phi : ndarray, shape (N, N)
    G : ndarray, shape (K + 1, ..., N)
    groups : list of ndarray, optional
        As for :func:`linear_recursion` (the blocks of Phi^T are those of Phi).

    Returns
    -------
    ndarray, shape (K + 1, ..., N)
    """
    G = np.asarray(G, float)
    Phi_T = np.asarray(Phi, float).T
    if groups is None:
        groups = identical_block_groups(Phi_T)
    return linear_recursion(Phi_T, G[-2::-1], G[-1], groups)[::-1]

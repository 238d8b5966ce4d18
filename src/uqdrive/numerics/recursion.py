"""Linear recursions x_{k+1} = Phi x_k + d_k of one discretised system over many steps, in a few
batched matrix products instead of one Python step per sample (nested chunks, in place).
"""

from __future__ import annotations

import functools

import numpy as np

__all__ = [
    "consecutive_slice",
    "decoupled_blocks",
    "identical_block_groups",
    "linear_recursion",
    "linear_recursion_in_place",
    "multilevel_batched",
    "reverse_linear_recursion",
]


def decoupled_blocks(pattern) -> list[np.ndarray]:
    """Index sets of the decoupled blocks of a square sparsity pattern (connected components).

    Parameters
    ----------
    pattern : ndarray of bool, shape (N, N)

    Returns
    -------
    list of ndarray of int (read-only)
        One index array, shape (b,), per block of size b; together they cover range(N).
    """
    pattern = np.asarray(pattern, bool)
    symmetric = pattern | pattern.T
    # A model's pattern is the same at every parameter value: the graph search (scipy's sparse
    # machinery, ~0.3 ms) runs once per pattern, the lookup costs microseconds.
    return list(_components(symmetric.shape[0], np.packbits(symmetric).tobytes()))


@functools.lru_cache(maxsize=32)
def _components(n, packed: bytes) -> tuple:
    # Imported here: scipy.sparse costs ~0.4 s of CPU at import, and most workflow jobs (statistics,
    # figures, scorecards) import this module through uqdrive.io without ever decoupling a model.
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import connected_components

    pattern = np.unpackbits(np.frombuffer(packed, np.uint8), count=n * n).reshape(n, n).astype(bool)
    count, labels = connected_components(csr_matrix(pattern), directed=False)
    blocks = tuple(np.flatnonzero(labels == c) for c in range(count))
    for b in blocks:
        b.setflags(write=False)
    return blocks


def consecutive_slice(idx):
    """The slice equal to an index array that is a run of consecutive indices, else None.

    Parameters
    ----------
    idx : ndarray of int, any shape (read in C order)

    Returns
    -------
    slice or None
    """
    flat = np.ravel(idx)
    if flat.size and np.array_equal(flat, np.arange(flat[0], flat[0] + flat.size)):
        return slice(int(flat[0]), int(flat[0]) + flat.size)
    return None


_DIRECT_STEPS = 4  # up to this many steps, the plain step-by-step loop
# One block recursion costs ~45 steps of a few numpy calls, ~0.2 ms: the time of ~8 MFLOP of
# small matrix products on one core. Blocks whose separate recursions would save less arithmetic
# than that per extra group are advanced together as one dense system.
_GROUP_OVERHEAD_FLOPS = 8e6


def _multilevel_in_place(Phi_T, out):
    """x_{k+1} = x_k Phi_T + d_k (row vectors) in place: out (K + 1, ..., n), any strides, holds
    x_0 and d_0..d_{K-1} on entry and x_0..x_K on return; the middle axes are independent systems.

    The first C L steps are cut into C chunks of L ~ K^(1/3) steps. Pass 1 runs all chunks at once
    from zero to get each chunk's end state; the chunk starts obey the same recursion with
    Phi^L over C steps, solved by this function again (so the levels nest); pass 2 runs all
    chunks at once from their true starts, adding onto the drive in place; the last K - C L < L
    steps run one by one. That is about 2 (L + L' + ...) + log K small products instead of K
    (~45 for K = 1000, against 95 for one level of sqrt(K) chunks), with about twice the
    arithmetic of the plain loop: the same sums in another order, equal to round-off for a
    stable or marginally stable Phi (powers up to Phi^L of each level are formed).
    """
    multilevel_batched(Phi_T[None], out[None])


def multilevel_batched(Phi_T, out):
    """x_{k+1} = x_k Phi_T[b] + d_k (row vectors) in place for every member b.

    The nested chunks of :func:`_multilevel_in_place` (L ~ K^(1/3) steps, chunk starts by the
    same recursion with Phi^L), every product one stacked ``matmul`` over the members; one
    system is the batch of one.

    Parameters
    ----------
    Phi_T : ndarray, shape (B, n, n)
        Transposed one-step transition of each member.
    out : ndarray, shape (B, K + 1, ..., n), any strides
        x_0 and d_0..d_{K-1} on entry, x_0..x_K on return; the middle axes are independent
        systems of the same member.
    """
    B, K = out.shape[0], out.shape[1] - 1
    tail = out.shape[2:]
    n = tail[-1]
    done = 0
    if K > _DIRECT_STEPS:
        L = max(2, int(round(K ** (1.0 / 3.0))))
        C = K // L
        z = out[:, 1 : C * L + 1].reshape((B, C, L) + tail)  # z[:, c, i] holds x_{c L + i + 1}
        end = np.reshape(z[:, :, 0], (B, -1, n))
        for i in range(1, L):
            end = end @ Phi_T
            end.reshape((B, C) + tail)[...] += z[:, :, i]
        starts = np.empty((B, C) + tail)
        starts[:, 0] = out[:, 0]
        starts[:, 1:] = end.reshape((B, C) + tail)[:, :-1]
        multilevel_batched(np.linalg.matrix_power(Phi_T, L), starts)
        state = starts.reshape(B, -1, n)
        for i in range(L):
            z[:, :, i] += (state @ Phi_T).reshape((B, C) + tail)
            state = np.reshape(z[:, :, i], (B, -1, n))
        done = C * L
    for k in range(done, K):
        out[:, k + 1] += (np.reshape(out[:, k], (B, -1, n)) @ Phi_T).reshape((B,) + tail)


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
    groups : list of ndarray of int, optional
        Index arrays, shape (n_blocks, b) each: block structure of Phi from :func:`identical_block_groups` (computed if omitted); each
        group of identical blocks is advanced as one batch.

    Returns
    -------
    ndarray, shape (K + 1, ..., N)
    """
    drive = np.asarray(drive, float)
    out = np.empty((drive.shape[0] + 1,) + drive.shape[1:])
    out[0] = 0.0 if x0 is None else x0
    out[1:] = drive
    return linear_recursion_in_place(Phi, out, groups)


def linear_recursion_in_place(Phi, out, groups=None):
    """:func:`linear_recursion` writing the states over the drive.

    Parameters
    ----------
    Phi : ndarray, shape (N, N)
    out : ndarray, shape (K + 1, ..., N)
        x_0 in ``out[0]`` and d_0..d_{K-1} in ``out[1:]`` on entry; x_0..x_K on return. Callers
        that form the drive straight in ``out`` save a copy of the largest array.
    groups : list of ndarray of int, optional
        As for :func:`linear_recursion`, shape (n_blocks, b) each.

    Returns
    -------
    ndarray, shape (K + 1, ..., N)
        ``out``.
    """
    Phi = np.asarray(Phi, float)
    if groups is None:
        groups = identical_block_groups(Phi)
    N, K = Phi.shape[0], out.shape[0] - 1
    batch = out[0].size // max(N, 1)
    blocks_flops = sum(idx.shape[0] * idx.shape[1] ** 2 for idx in groups)
    if len(groups) > 1 and 4 * K * batch * (N * N - blocks_flops) < (len(groups) - 1) * _GROUP_OVERHEAD_FLOPS:
        groups = [np.arange(N)[None]]
    for idx in groups:
        first = idx[0]
        block_T = np.ascontiguousarray(Phi[np.ix_(first, first)].T)
        run = consecutive_slice(idx)
        if run is not None:
            # Consecutive states (a block-ordered layout): a view, recursed in place.
            view = out[..., run].reshape(out.shape[:-1] + idx.shape)
            _multilevel_in_place(block_T, view)
        else:
            part = out[..., idx]
            _multilevel_in_place(block_T, part)
            out[..., idx] = part
    return out


def reverse_linear_recursion(Phi, G, groups=None):
    """Adjoint states lambda_K = G_K, lambda_k = G_k + Phi^T lambda_{k+1} (backward in time).

    Parameters
    ----------
    Phi : ndarray, shape (N, N)
    G : ndarray, shape (K + 1, ..., N)
    groups : list of ndarray of int, optional
        As for :func:`linear_recursion`, shape (n_blocks, b) each (the blocks of Phi^T are those of Phi).

    Returns
    -------
    ndarray, shape (K + 1, ..., N)
    """
    G = np.asarray(G, float)
    Phi_T = np.asarray(Phi, float).T
    if groups is None:
        groups = identical_block_groups(Phi_T)
    out = np.empty_like(G)
    out[0] = G[-1]
    out[1:] = G[-2::-1]
    return linear_recursion_in_place(Phi_T, out, groups)[::-1]

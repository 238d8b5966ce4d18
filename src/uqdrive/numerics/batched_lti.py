"""A batch of discretised LTI systems of one structure (e.g. one Galerkin model at many parameter
values, the walkers of an MCMC ensemble): exact first-order-hold discretisation and responses to
shared inputs with a leading batch axis: the maps of the one-system kernels of
:mod:`uqdrive.numerics.integrate` (Van Loan's exponential, here by scaling and squaring on each
block) and their recursion, so a batch of one theta gives the one-system numbers to rounding.

The batch shares the block structure of its matrices (decoupled blocks, groups of identical
blocks, which inputs reach which block): it is read from the union of the members' sparsity
patterns, which for a model at generic parameter values is the structure of every member.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from .discretise import foh_discretise
from .recursion import multilevel_batched, consecutive_slice, decoupled_blocks

__all__ = [
    "BlockGroup",
    "batched_block_groups",
    "block_diagonal",
    "foh_discretise_batched",
    "linear_recursion_batched",
    "lti_response_batched",
]

_ALL = slice(None)


@dataclass(frozen=True)
class BlockGroup:
    """Decoupled blocks of one batch that share their matrices (e.g. the Galerkin terms of each
    KLE germ): one exponential and one recursion per member serve all of them.

    Attributes
    ----------
    index : ndarray of int, shape (m, b)
        State indices of the m blocks of size b.
    run : slice or None
        ``index`` as one run of consecutive states (block-ordered layouts), else None.
    squares : tuple of index tuples
        Per block, the (rows, columns) index of its square in an N x N matrix.
    rects : tuple of index tuples
        Per block, the (rows, input columns) index of the inputs that reach it in N x r (all
        inputs when the matrix is one block, as :func:`uqdrive.numerics.integrate.foh_discretise_single`).
    widths : tuple of int
        Per block, the number of those input columns.
    """

    index: np.ndarray
    run: slice | None
    squares: tuple
    rects: tuple
    widths: tuple


def batched_block_groups(A, E=None) -> list[BlockGroup]:
    """Decoupled blocks of a batch of matrices, grouped when identical in every member.

    Parameters
    ----------
    A : ndarray, shape (B, N, N)
    E : ndarray, shape (B, N, r), optional
        Input matrices: which columns reach each block (``rects``); all columns if omitted.

    Returns
    -------
    list of BlockGroup
        The structure (blocks, candidate groups, index tuples) is cached per sparsity pattern;
        that the blocks of a group are identical is checked on every call (blocks that differ
        in some member are split into groups of their own).
    """
    A = np.asarray(A)
    N = A.shape[-1]
    reach = np.ones((N, 1), bool) if E is None else np.any(np.asarray(E) != 0, axis=0)
    pattern = np.any(A != 0, axis=0)
    candidates = _candidate_groups(N, reach.shape[1], np.packbits(pattern).tobytes(), np.packbits(reach).tobytes())
    out = []
    for group in candidates:
        first = A[(_ALL,) + group.squares[0]]
        if all(np.array_equal(A[(_ALL,) + sq], first) for sq in group.squares[1:]):
            out.append(group)
            continue
        split: dict = {}
        for k, sq in enumerate(group.squares):
            split.setdefault(A[(_ALL,) + sq].tobytes(), []).append(k)
        out += [_group([group.index[k] for k in ks], reach) for ks in split.values()]
    return out


@functools.lru_cache(maxsize=32)
def _candidate_groups(N, r, pattern: bytes, reach: bytes) -> tuple:
    """Blocks of the pattern, grouped by size (candidates for identical blocks)."""
    reach_ = np.unpackbits(np.frombuffer(reach, np.uint8), count=N * r).reshape(N, r).astype(bool)
    pattern_ = np.unpackbits(np.frombuffer(pattern, np.uint8), count=N * N).reshape(N, N).astype(bool)
    blocks = decoupled_blocks(pattern_)
    if len(blocks) == 1:
        reach_[:] = True
    by_size: dict = {}
    for idx in blocks:
        by_size.setdefault(idx.size, []).append(idx)
    return tuple(_group(members, reach_) for members in by_size.values())


def _group(members, reach) -> BlockGroup:
    index = np.stack(members)
    index.setflags(write=False)
    columns = [np.flatnonzero(np.any(reach[idx], axis=0)) for idx in members]
    squares = tuple(_ix(idx, idx) for idx in members)
    rects = tuple(_ix(idx, cols) for idx, cols in zip(members, columns))
    return BlockGroup(index, consecutive_slice(index), squares, rects, tuple(c.size for c in columns))


def block_diagonal(blocks, N: int) -> np.ndarray:
    """Assemble the (B, N, N) matrices of a block-diagonal batch.

    Parameters
    ----------
    blocks : list of (BlockGroup, ndarray of shape (B, b, b))
        Each group's shared block matrix (as returned by :func:`foh_discretise_batched`).
    N : int

    Returns
    -------
    ndarray, shape (B, N, N)
    """
    B = blocks[0][1].shape[0]
    out = np.zeros((B, N, N))
    for group, M in blocks:
        for sq in group.squares:
            out[(_ALL,) + sq] = M
    return out


def _ix(rows, cols):
    """Index of a sub-matrix: slices for runs of consecutive indices, else ``np.ix_``."""
    row_run, col_run = consecutive_slice(rows), consecutive_slice(cols)
    if row_run is None:
        return np.ix_(rows, cols)
    return row_run, cols if col_run is None else col_run


def foh_discretise_batched(A, E, h: float):
    """Exact first-order-hold discretisation of B systems x' = A_b x + E_b g(t) of one structure.

    x_{k+1} = Phi x_k + P g_k + Q g_{k+1} with Phi = e^{A h}, Q = Gamma_1 / h, P = Gamma_0 - Q,
    the maps of Van Loan's block exponential per member, computed on the b x b blocks by
    :func:`uqdrive.numerics.discretise.foh_discretise` (scaling and squaring of e^X, phi_1, phi_2:
    the block with its inputs, b + 2 r wide, would cost ((b + 2r) / b)^3 times the arithmetic
    per product), to rounding the maps of the one-system kernel. As in
    :func:`uqdrive.numerics.integrate.foh_discretise_single`, decoupled blocks are discretised one at a
    time with only the inputs that reach them, and groups of identical blocks share one
    exponential (their inputs are extra columns of the same Van Loan block), so each member's
    maps are the one-system maps.

    Parameters
    ----------
    A : ndarray, shape (B, N, N)
    E : ndarray, shape (B, N, r)
    h : float
        Step (s).

    Returns
    -------
    blocks : list of (BlockGroup, ndarray of shape (B, b, b))
        Phi, block diagonal: each group's shared block (:func:`block_diagonal` assembles it).
    P, Q : ndarray, shape (B, N, r)
    """
    A = np.asarray(A, float)
    E = np.asarray(E, float)
    B, N, r = E.shape
    groups = batched_block_groups(A, E)
    P, Q = np.zeros((B, N, r)), np.zeros((B, N, r))
    blocks = []
    for group in groups:
        E_group = np.concatenate([E[(_ALL,) + rect] for rect in group.rects], axis=-1) if len(group.rects) > 1 else E[(_ALL,) + group.rects[0]]
        Phi_b, P_b, Q_b = foh_discretise(A[(_ALL,) + group.squares[0]], E_group, h)
        blocks.append((group, Phi_b))
        start = 0
        for rect, width in zip(group.rects, group.widths):
            P[(_ALL,) + rect], Q[(_ALL,) + rect] = P_b[..., start : start + width], Q_b[..., start : start + width]
            start += width
    return blocks, P, Q


def linear_recursion_batched(blocks, out):
    """States of x_{k+1} = Phi_b x_k + d_k for B members at once, in place, block group by group.

    Parameters
    ----------
    blocks : list of (BlockGroup, ndarray of shape (B, b, b))
        Phi, block diagonal (as from :func:`foh_discretise_batched`); a group of m identical
        blocks advances as m independent systems of one b x b matrix per member.
    out : ndarray, shape (B, K + 1, N)
        x_0 in ``out[:, 0]`` and d_0..d_{K-1} in ``out[:, 1:]`` on entry; x_0..x_K on return.

    Returns
    -------
    ndarray, shape (B, K + 1, N)
        ``out``.
    """
    for group, Phi_b in blocks:
        Phi_T = np.ascontiguousarray(Phi_b.swapaxes(-1, -2))
        if group.run is not None:
            multilevel_batched(Phi_T, out[..., group.run].reshape(out.shape[:2] + group.index.shape))
        else:
            part = out[..., group.index]  # (B, K + 1, m, b), a copy
            multilevel_batched(Phi_T, part)
            out[..., group.index] = part
    return out


def lti_response_batched(blocks, P, Q, g, x0=0.0, every: int = 1):
    """Responses of B discretised systems to shared sampled inputs, at every ``every``-th sample.

    x_{k+1} = Phi_b x_k + d_k with d_k = P_b g_k + Q_b g_{k+1}: the drives of all steps are one
    stacked GEMM, then the batched recursion. With ``every`` = s > 1 only x_0, x_s, x_2s, ...
    (up to the last multiple of s <= K) are formed: within each window of s steps the
    recursion runs from zero for all windows at once (s - 1 batched products), which gives
    the window's total drive D_j = sum_i Phi^(s-1-i) d_(js+i), and the states at the window
    ends obey x_(j+1)s = Phi^s x_js + D_j, a recursion s times shorter. The same discretised
    system, observed less often (equal to the every-step states up to rounding).

    Parameters
    ----------
    blocks : list of (BlockGroup, ndarray of shape (B, b, b))
        Phi, block diagonal (from :func:`foh_discretise_batched`).
    P, Q : ndarray, shape (B, N, r)
    g : ndarray, shape (K + 1, r)
        Inputs on the output grid, shared by the members.
    x0 : float or ndarray, shape (N,) or (B, N)
    every : int, optional

    Returns
    -------
    ndarray, shape (B, K // every + 1, N)
    """
    g = np.asarray(g, float)
    B, N = P.shape[:2]
    s = int(every)
    if s < 1:
        raise ValueError(f"every must be a positive integer, got {every}")
    K = (g.shape[0] - 1) // s
    pairs = np.concatenate([g[: K * s], g[1 : K * s + 1]], axis=1)  # (K s, 2 r)
    x = np.empty((B, K * s + 1, N))
    x[:, 0] = x0
    np.matmul(pairs, np.concatenate([P, Q], axis=-1).swapaxes(-1, -2), out=x[:, 1:])
    if s == 1:
        return linear_recursion_batched(blocks, x)
    out = np.empty((B, K + 1, N))
    out[:, 0] = x[:, 0]
    for group, Phi_b in blocks:
        Phi_T = np.ascontiguousarray(Phi_b.swapaxes(-1, -2))
        sel = group.run if group.run is not None else group.index.ravel()
        shape = group.index.shape
        window = x[:, 1:, sel].reshape((B, K, s) + shape)  # window[:, j, i] = d_(js+i)
        end = np.reshape(window[:, :, 0], (B, -1, shape[-1]))
        for i in range(1, s):
            end = end @ Phi_T
            end.reshape((B, K) + shape)[...] += window[:, :, i]
        coarse = np.empty((B, K + 1) + shape)
        coarse[:, 0] = out[:, 0, sel].reshape((B,) + shape)
        coarse[:, 1:] = end.reshape((B, K) + shape)
        multilevel_batched(np.linalg.matrix_power(Phi_T, s), coarse)
        out[:, :, sel] = coarse.reshape((B, K + 1, -1))
    return out

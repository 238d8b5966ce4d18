"""The RK4 stepper of the chassis ensembles with its array arithmetic compiled: each stage's
state and the step's combination one loop, the numbers of :func:`uqdrive.numerics.integrate.rk4_fixed_step_into` bit for bit.

Per step the NumPy stepper makes ten passes over the (n_states, n) states, each a NumPy call
whose cost at a discover fit's few hundred to few thousand realisations is mostly per call;
here four, each element computed by the same operations in the same order (no multiply-add
contraction without fastmath).
"""

from __future__ import annotations

import numpy as np

from .jit import compiled

__all__ = ["rk4_fused_into"]


@compiled
def _stage(k, c, x, xs):
    """xs = c k + x (np.multiply(k, c, xs); xs += x), element by element, for arrays of one shape."""
    k1, x1, s1 = k.reshape(-1), x.reshape(-1), xs.reshape(-1)
    for i in range(k1.shape[0]):
        s1[i] = k1[i] * c + x1[i]


@compiled
def _advance(x, k1, k2, k3, k4, sixth):
    """x += (h / 6) (k1 + 2 (k2 + k3) + k4) in the NumPy stepper's order: ((((k2 + k3) 2) + k1) + k4) sixth."""
    x_, a, b, c, d = x.reshape(-1), k1.reshape(-1), k2.reshape(-1), k3.reshape(-1), k4.reshape(-1)
    for i in range(x_.shape[0]):
        s = b[i] + c[i]
        s = s * 2.0
        s = s + a[i]
        s = s + d[i]
        s = s * sixth
        x_[i] = x_[i] + s


def rk4_fused_into(rhs, x0, h: float, n_steps: int, record_every: int):
    """:func:`uqdrive.numerics.integrate.rk4_fixed_step_into`, the same numbers, with its array
    arithmetic in compiled loops (the right-hand side is called as there).

    Parameters
    ----------
    rhs : callable
        ``rhs(x, j, out)`` writes dx/dt at time j h / 2 for the state ``x`` (d, n) into ``out`` (d, n).
    x0 : array_like, shape (d, n)
        Initial state.
    h : float
        Step (s).
    n_steps, record_every : int
        Steps, and the steps between two recorded states (a divisor of ``n_steps``).

    Returns
    -------
    ndarray, shape (n_steps // record_every + 1, d, n)
        The state at every ``record_every``-th step, the initial one first.
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
        _stage(k1, half, x, xs)
        rhs(xs, j + 1, k2)
        _stage(k2, half, x, xs)
        rhs(xs, j + 1, k3)
        _stage(k3, h, x, xs)
        rhs(xs, j + 2, k4)
        _advance(x, k1, k2, k3, k4, sixth)
        if (i + 1) % record_every == 0:
            out[(i + 1) // record_every] = x
    return out

"""The classical RK4 step of the JAX ensembles, on states carried row by row (a tuple of arrays
(n,)): the NumPy stepper's operations in its order (:func:`uqdrive.numerics.integrate.rk4_fixed_step_into`).
"""

from __future__ import annotations

import numpy as np

__all__ = ["rk4_rows_step", "per_step"]


def rk4_rows_step(stage, x: tuple, inputs, h: float) -> tuple:
    """One RK4 step of the states ``x`` (a tuple of d arrays, shape (n,) each).

    Parameters
    ----------
    stage : callable
        ``stage(x, inputs, k)``: dx/dt (a tuple like ``x``) at the step's start (k = 0), middle
        (1) and end (2), from the step's ``inputs``.
    x : tuple of arrays, shape (n,) each
        The states at the step's start.
    inputs
        The step's inputs, passed to ``stage``.
    h : float
        Step (s).

    Returns
    -------
    tuple of arrays, shape (n,) each
        The states at the step's end: x + h (k1 + 2 k2 + 2 k3 + k4) / 6, summed as the NumPy
        stepper sums (((k2 + k3) 2 + k1) + k4) h / 6, each stage's state formed as k scale + x.
    """
    half, sixth = 0.5 * h, h / 6.0

    def shifted(k, scale):
        return tuple(k_i * scale + x_i for x_i, k_i in zip(x, k))

    k1 = stage(x, inputs, 0)
    k2 = stage(shifted(k1, half), inputs, 1)
    k3 = stage(shifted(k2, half), inputs, 1)
    k4 = stage(shifted(k3, h), inputs, 2)
    return tuple(x_i + ((((b + c) * 2.0) + a) + d) * sixth for x_i, a, b, c, d in zip(x, k1, k2, k3, k4))


def per_step(half, n_steps: int, record_every: int) -> np.ndarray:
    """Values on the half-step grid, shape (2 ``n_steps`` + 1, ...), as (K, R, 3, ...) with
    R = ``record_every`` and K = ``n_steps`` / R: each step's values at its start, middle and end
    (half steps j, j + 1, j + 2), grouped by recorded interval."""
    index = 2 * np.arange(n_steps)[:, None] + np.arange(3)
    return np.asarray(half, float)[index].reshape((n_steps // record_every, record_every, 3) + np.shape(half)[1:])

"""The RK4 stepper of the chassis ensembles with its array arithmetic compiled: each stage's
state and the step's combination one loop, the numbers of :func:`uqdrive.numerics.integrate.rk4_fixed_step_into` bit for bit.

Per step the NumPy stepper makes ten passes over the (n_states, n) states, each a NumPy call
whose cost at a discover fit's few hundred to few thousand realisations is mostly per call;
here four, each element computed by the same operations in the same order (no multiply-add
contraction without fastmath).
"""

from __future__ import annotations

from ...numerics.integrate import rk4_fixed_step_into
from .jit import compiled

__all__ = ["rk4_fused_into"]


@compiled
def _stage(k, c, x, xs):
    """xs = c k + x, element by element (numerics.integrate.rk4_stage), for C-contiguous arrays of one shape."""
    k1, x1, s1 = k.reshape(-1), x.reshape(-1), xs.reshape(-1)
    for i in range(k1.shape[0]):
        s1[i] = k1[i] * c + x1[i]


@compiled
def _advance(x, k1, k2, k3, k4, sixth):
    """x += (h / 6) (k1 + 2 (k2 + k3) + k4) in numerics.integrate.rk4_advance's order: ((((k2 + k3) 2) + k1) + k4) sixth."""
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
        Initial state (each row in its state's unit: rad, rad/s, rad, m, ...).
    h : float
        Step (s).
    n_steps, record_every : int
        Steps, and the steps between two recorded states (a divisor of ``n_steps``).

    Returns
    -------
    ndarray, shape (n_steps // record_every + 1, d, n)
        The state at every ``record_every``-th step, the initial one first.
    """
    return rk4_fixed_step_into(rhs, x0, h, n_steps, record_every, stage=_stage, advance=_advance)

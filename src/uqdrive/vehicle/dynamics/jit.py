"""How the compiled loops of the dynamics (:mod:`.ltv_rk4`, :mod:`.load_newton`, :mod:`.fused_rates`)
are compiled (numba's njit, cached on disk where a place is writable) and how they are given a
value per realisation.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["compiled", "realisations"]


def compiled(py_func):
    """``py_func`` compiled at its first call, the machine code cached beside the module (or in
    the user's cache); with no writable place numba refuses to cache: then compiled anew per process.

    error_model "numpy": a division by zero gives inf or nan as NumPy's does, and the loop carries
    no branch to raise it (a branch there keeps LLVM from vectorising the loop).
    """
    try:
        return njit(cache=True, nogil=True, error_model="numpy")(py_func)
    except RuntimeError:  # "cannot cache function ...: no locator available"
        return njit(nogil=True, error_model="numpy")(py_func)


def realisations(a, n: int):
    """``a`` (a number or an array broadcasting to (n,)) as a C-contiguous float64 array of shape
    (n,), the same values: what a compiled loop indexes per realisation (an array that already is
    one is passed through, read-only where the broadcast made it so)."""
    return np.ascontiguousarray(np.broadcast_to(np.asarray(a, float), (n,)))

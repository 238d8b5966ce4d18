"""How the compiled loops of the dynamics (:mod:`.ltv_rk4`, :mod:`.load_newton`, :mod:`.fused_rates`)
are compiled (numba's njit, cached on disk where a place is writable) and how they are given a
value per realisation.

Their helpers are plain ``njit`` functions, which LLVM inlines; ``inline="always"`` (numba inlines
the helper's code and types it anew at each call site) is kept for the helpers that take a term's
flag or a state row the loop fixes (``_loads``, the roll mode, the steady slip), so that the flag
folds away before LLVM vectorises the loop. Inlining every helper that way made a clean
checkout's tests/test_fused_chassis.py compile for 65-85 s instead of 40-55 s, for no speed
(benchmarks/bench_fused_chassis.py's and bench_fused_rates.py's per-call rows unchanged).
"""

from __future__ import annotations

import llvmlite.binding as llvm
import numpy as np
from numba import njit

__all__ = ["MEMORY_CHECKS", "compiled", "factor", "realisations"]

#: The runtime alias checks LLVM's loop vectoriser may add to one loop. numba cannot tell LLVM that
#: the arrays it passes do not overlap, so a loop that stores to ~14 rows and reads ~20 (the loads'
#: step of the load-sensitive tyre, :func:`.load_newton.loads_step`) needs some 400 checks of their
#: address ranges; LLVM's limits (8, up to 128 where its cost model finds them paid for) left such
#: loops scalar (benchmarks/bench_memory_checks.py). The checks cost a few hundred comparisons a
#: call, and where arrays do overlap the scalar loop runs: the numbers are the same either way.
#: LLVM's options are global: set at import, for every loop compiled after it in the process.
MEMORY_CHECKS = 512
for _option in ("runtime-memory-check-threshold", "vectorize-memory-check-threshold"):
    llvm.set_option("uqdrive", f"--{_option}={MEMORY_CHECKS}")


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


_FLOAT64 = np.dtype(np.float64)


def realisations(a, n: int):
    """``a`` (a number or an array broadcasting to (n,)) as a C-contiguous float64 array of shape
    (n,), the same values: what a compiled loop indexes per realisation. An array that already is
    one, and writable, is returned itself (checked in ~0.3 us: the right-hand sides pass a half
    step's inputs through here on every call, where the broadcast and its checks cost ~4 us); any
    other is copied, so that a loop sees one array type (numba compiles a read-only array's loop
    anew, ~1 s a loop on a cold cache)."""
    flags = a.flags if a.__class__ is np.ndarray else None
    if flags is not None and a.shape == (n,) and a.dtype is _FLOAT64 and flags.c_contiguous:
        return a if flags.writeable else a.copy()
    out = np.ascontiguousarray(np.broadcast_to(np.asarray(a, float), (n,)))
    return out if out.flags.writeable else out.copy()  # an (n,) array comes back as its read-only broadcast view


def factor(a, n: int):
    """A tyre factor (B, C) as a compiled loop reads it through ``item``: one float where ``a``
    holds one value (the loop compiled for a number, as before), else :func:`realisations` (n,):
    a pass of pairs whose tyres differ gives each realisation its own."""
    return float(np.reshape(a, ())) if np.size(a) == 1 else realisations(a, n)

"""How the compiled loops of the dynamics (:mod:`.ltv_rk4`, :mod:`.load_newton`, :mod:`.fused_rates`)
are compiled (numba's njit, cached on disk where a place is writable, :class:`KernelCache`) and how
they are given a value per realisation.

Their helpers are plain ``njit`` functions, which LLVM inlines; ``inline="always"`` (numba inlines
the helper's code and types it anew at each call site) is kept for the helpers that take a term's
flag or a state row the loop fixes (``_loads``, the roll mode, the steady slip), so that the flag
folds away before LLVM vectorises the loop. Inlining every helper that way made a clean
checkout's tests/test_fused_chassis.py compile for 65-85 s instead of 40-55 s, for no speed
(benchmarks/bench_fused_chassis.py's and bench_fused_rates.py's per-call rows unchanged).
"""

from __future__ import annotations

import functools
import hashlib
from pathlib import Path

import llvmlite.binding as llvm
import numpy as np
from numba.core import config as numba_config
from numba.core.caching import FunctionCache
from numba.core.dispatcher import Dispatcher
from numba.core.registry import CPUDispatcher
from numba.core.serialize import dumps

__all__ = ["MEMORY_CHECKS", "KernelCache", "calls_closures", "compiled", "variant_name", "factor", "realisations", "sources_digest"]

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


@functools.lru_cache(maxsize=None)
def sources_digest(folder: str) -> str:
    """sha256 of the sources of every module in ``folder`` (a package of compiled loops and the
    helpers they call: :mod:`uqdrive.vehicle.dynamics`), read once per process."""
    h = hashlib.sha256()
    for path in sorted(Path(folder).glob("*.py")):
        h.update(path.name.encode() + b"\0" + path.read_bytes())
    return h.hexdigest()


def calls_closures(py_func) -> bool:
    """Whether ``py_func`` closes over compiled loops (none of this package's loops do:
    :func:`.load_newton.newton_loop` inlines its passes). Such a loop is compiled anew in every
    process, never cached: numba keys a closure's cache by its cells' values, and pickles a
    compiled loop with an identifier drawn per process, so its cache would never be found again
    and would hold one file more per process."""
    return any(isinstance(cell.cell_contents, Dispatcher) for cell in py_func.__closure__ or ())


def variant_name(py_func) -> str:
    """The name a closure is compiled under: its own, tagged by the values of its cells.

    numba names a compiled function's symbol by its qualified name and a counter of the
    compiling process. Two variants of a closure (the same code, other values in its cells)
    compiled in processes forked from one state (a discover's workers) would get one symbol, and
    a loop compiled in a process that loaded both from the cache would call one variant for both
    (a Newton pass and a final pass: the final pass twice, the Newton step never taken).
    tests/test_kernel_cache.py builds that case."""
    if not py_func.__closure__:
        return py_func.__qualname__
    cells = dumps(tuple(cell.cell_contents for cell in py_func.__closure__))
    return f"{py_func.__qualname__}_{hashlib.sha256(cells).hexdigest()[:12]}"


class KernelCache(FunctionCache):
    """numba's cache of a compiled loop, its index keyed also by the :func:`sources_digest` of
    the loop's package.

    numba keys a function's machine code by its own bytecode, its closure's values and its
    source file's time stamp: a loop's cached code would keep the old code of a helper it calls
    in another module (:mod:`.fused_rates`' half angles in every chassis loop) after an edit
    of that module alone. The digest keys every loop by all the code it can call."""

    def _index_key(self, sig, codegen):
        return (*super()._index_key(sig, codegen), sources_digest(str(Path(self._py_func.__code__.co_filename).parent)))


class _Kernel(CPUDispatcher):
    """numba's CPU dispatcher cached by :class:`KernelCache`."""

    def enable_caching(self):
        self._cache = KernelCache(self.py_func)


def compiled(py_func):
    """``py_func`` compiled at its first call under its :func:`variant_name`, the machine code
    cached beside the module (or in the user's cache, :class:`KernelCache`); with no writable
    place numba refuses to cache, and a loop that :func:`calls_closures` is not cached: then
    compiled anew per process.

    error_model "numpy": a division by zero gives inf or nan as NumPy's does, and the loop carries
    no branch to raise it (a branch there keeps LLVM from vectorising the loop).
    """
    if numba_config.DISABLE_JIT:  # NUMBA_DISABLE_JIT=1: the Python loop, as numba's njit gives it
        return py_func
    py_func.__qualname__ = variant_name(py_func)
    kernel = _Kernel(py_func=py_func, locals={}, targetoptions={"nopython": True, "nogil": True, "error_model": "numpy", "boundscheck": None})
    if calls_closures(py_func):
        return kernel
    try:
        kernel.enable_caching()
    except RuntimeError:  # "cannot cache function ...: no locator available"
        pass
    return kernel


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

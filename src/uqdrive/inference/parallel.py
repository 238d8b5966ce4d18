"""Independent computations (the candidate fits of one discover step) in forked worker processes,
their results returned with every object the parent already holds (simulators, memo) by reference.

A forked worker starts with the parent's memory: the data, the simulators and their compiled
kernels are there without being sent. Only the results travel back, pickled; an object that
existed in the parent before the fork (:func:`fork_map`'s ``shared``) is pickled as a reference
and read back as the parent's own object, so a fit made in a worker holds the same simulator as
one made in the parent. Each item is computed from the same inputs as in a loop, so the results
are the loop's, bit for bit, where no item depends on what an earlier one changed (discover's
shared memo of simulations is such a change that does not matter: a simulation it holds has the
numbers of one made anew, :class:`uqdrive.inference.discrepancy.fitter.SimulationMemo`).
"""

from __future__ import annotations

import io
import multiprocessing
import os
import pickle
import signal
import traceback
from typing import Any, Callable, Iterable, Sequence

from ..numerics.threads import borrow_idle_cores, no_spare_core

__all__ = ["available", "fork_map", "resolve_jobs"]

#: Set in a worker: a map called inside a worker's item runs as a loop (no workers of workers).
_IN_WORKER = {"yes": False}


def available() -> bool:
    """Whether worker processes can be forked here (POSIX; not on Windows)."""
    return "fork" in multiprocessing.get_all_start_methods()


def resolve_jobs(jobs: int | str | None) -> int:
    """Worker processes for ``jobs``: a positive count, or ``"auto"`` (the CPUs this process may
    use, :func:`os.sched_getaffinity` where it exists); 1 where forking is not available.

    Raises
    ------
    ValueError
        For a count below 1 or a string other than ``"auto"``, naming the value.
    """
    if jobs is None:
        return 1
    if isinstance(jobs, str):
        if jobs.strip().lower() != "auto":
            try:
                jobs = int(jobs)
            except ValueError:
                raise ValueError(f"jobs must be a positive whole number or 'auto', got {jobs!r}") from None
        else:
            jobs = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    if isinstance(jobs, bool) or int(jobs) != jobs or int(jobs) < 1:
        raise ValueError(f"jobs must be a positive whole number or 'auto', got {jobs!r}")
    return int(jobs) if available() else 1


class _ReferencePickler(pickle.Pickler):
    """Pickles the objects of ``shared`` (by identity) as references the parent resolves."""

    def __init__(self, file, shared: dict):
        super().__init__(file, protocol=pickle.HIGHEST_PROTOCOL)
        self._shared = shared

    def persistent_id(self, obj):
        key = id(obj)
        return key if key in self._shared and self._shared[key] is obj else None


class _ReferenceUnpickler(pickle.Unpickler):
    def __init__(self, file, shared: dict):
        super().__init__(file)
        self._shared = shared

    def persistent_load(self, pid):
        return self._shared[pid]


def _dumps(value, shared: dict) -> bytes:
    buffer = io.BytesIO()
    _ReferencePickler(buffer, shared).dump(value)
    return buffer.getvalue()


def _loads(data: bytes, shared: dict):
    return _ReferenceUnpickler(io.BytesIO(data), shared).load()


def _worker(fn, items, shared, tasks, results, parent: int, idle=None) -> None:
    """A worker's loop: take an item's index, compute it, send ("ok", bytes), ("error", the
    exception pickled, its traceback) or ("local", None) for a result that cannot be pickled,
    which the parent then computes itself.

    The parent alone answers an interruption: a terminal's Ctrl-C reaches the whole process
    group, so the workers ignore it and end, silently, when the parent ends them (SIGTERM) or
    is gone (checked between items). A worker that finds no item left counts its core in the
    semaphore ``idle`` (None: none), which the others borrow for the fits they still compute."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    for signum in (signal.SIGTERM, signal.SIGHUP):
        signal.signal(signum, signal.SIG_DFL)
    _IN_WORKER["yes"] = True
    no_spare_core()  # the other workers hold the other cores
    if idle is not None:
        borrow_idle_cores(idle)
    while True:
        i = tasks.get()
        if i is None or os.getppid() != parent:
            if i is None and idle is not None:
                idle.release()  # this core, to the workers still computing
            return
        try:
            value = fn(items[i])
        except BaseException as error:  # the parent raises it, as the loop would have
            try:
                payload = pickle.dumps(error)
            except Exception:
                payload = pickle.dumps(RuntimeError(f"{type(error).__name__}: {error}"))
            results.put((i, "error", payload, traceback.format_exc()))
            continue
        try:
            results.put((i, "ok", _dumps(value, shared), ""))
        except Exception:
            results.put((i, "local", None, traceback.format_exc()))


def fork_map(fn: Callable[[Any], Any], items: Sequence, jobs: int, shared: Iterable[Any] = ()) -> list:
    """``[fn(item) for item in items]``, computed by up to ``jobs`` forked workers.

    Parameters
    ----------
    fn : callable
        Computes one item's result; it may read and change what it closes over in its worker,
        but such changes stay there: only the returned value reaches the parent.
    items : sequence
        The items, in the order of the returned list.
    jobs : int
        Worker processes at most; with 1, a single item, forking unavailable or when called
        inside a worker, the items are computed here, one after the other.
    shared : iterable
        Objects of the parent that results may hold (returned as the parent's objects, not copies).

    Returns
    -------
    list
        The results in the order of ``items``.

    An exception an item raised in its worker is raised here (the first in the items' order, the
    worker's traceback in its notes); the workers are ended before this returns or raises,
    whatever happens (an interruption included).
    """
    items = list(items)
    workers = min(int(jobs), len(items))
    if workers <= 1 or _IN_WORKER["yes"] or not available():
        return [fn(item) for item in items]
    refs = {id(obj): obj for obj in shared}
    ctx = multiprocessing.get_context("fork")
    tasks, results, idle = ctx.SimpleQueue(), ctx.SimpleQueue(), ctx.Semaphore(0)
    for i in range(len(items)):
        tasks.put(i)
    for _ in range(workers):
        tasks.put(None)
    procs = [ctx.Process(target=_worker, args=(fn, items, refs, tasks, results, os.getpid(), idle), daemon=True) for _ in range(workers)]
    out: dict[int, tuple] = {}
    try:
        for p in procs:
            p.start()
        while len(out) < len(items):
            if results.empty() and not any(p.is_alive() for p in procs):
                raise RuntimeError("the worker processes of a parallel search ended before their work (killed?)")
            if results.empty():
                for p in procs:
                    p.join(timeout=0.05)
                    if not results.empty():
                        break
                continue
            i, status, payload, trace = results.get()
            out[i] = (status, payload, trace)
    finally:
        for p in procs:
            if p.is_alive():
                p.terminate()
        for p in procs:
            p.join(timeout=5)
            if p.is_alive():  # not ended by SIGTERM within 5 s (stopped, or stuck in the kernel)
                p.kill()
                p.join()
    values = []
    for i, item in enumerate(items):
        status, payload, trace = out[i]
        if status == "error":
            error = pickle.loads(payload)
            error.add_note(f"raised in a worker process of uqdrive.inference.parallel.fork_map (item {i}):\n{trace.rstrip()}")
            raise error
        values.append(_loads(payload, refs) if status == "ok" else fn(item))
    return values

"""The cores a computation uses: one BLAS thread for the small-matrix kernels, and a forked process
beside this one for half of a batch where the caller has a core to spare (:func:`spare_core`) or
another worker left its core idle (:func:`borrow_idle_cores`).

OpenBLAS threads make products and solves of tens-by-tens matrices about twice as slow on a
2-core machine; a batch of independent parts (the RK4 passes of a fit's Jacobian) computed on two
cores while the other core would idle takes about half the time.
"""

from __future__ import annotations

import contextlib
import ctypes
import functools
import mmap
import os
import pickle
import signal
from os import _exit
from typing import Any, Callable, Sequence

from threadpoolctl import ThreadpoolController

__all__ = ["beside", "borrow_idle_cores", "has_spare_core", "no_spare_core", "single_blas_thread", "spare_core", "with_single_blas_thread"]

_PR_SET_PDEATHSIG = 1  # <linux/prctl.h>

#: Whether this process may fork one more process now (set by :func:`spare_core`), and the
#: semaphore counting the idle cores it may borrow one of (:func:`borrow_idle_cores`).
_SPARE: dict = {"core": False, "idle": None}


@functools.cache
def _controller() -> ThreadpoolController:
    # Scanning the loaded libraries costs ~1 ms; once scanned, a limit costs ~10 us.
    return ThreadpoolController()


def single_blas_thread():
    """Context manager that limits BLAS to one thread and restores the previous setting."""
    return _controller().limit(limits=1, user_api="blas")


def with_single_blas_thread(function):
    """Decorator: run ``function`` under :func:`single_blas_thread`."""

    @functools.wraps(function)
    def wrapper(*args, **kwargs):
        with single_blas_thread():
            return function(*args, **kwargs)

    return wrapper


@contextlib.contextmanager
def spare_core(spare: bool = True):
    """Within: :func:`beside` may fork a process (``spare``), e.g. while a search computes one
    item alone with a worker's core idle; without ``spare``, no core is borrowed either (the
    half of a batch that this process computes beside its child). Restores both on exit."""
    before = dict(_SPARE)
    _SPARE["core"] = bool(spare) and hasattr(os, "fork")
    if not spare:
        _SPARE["idle"] = None
    try:
        yield
    finally:
        _SPARE.update(before)


def _idle_now(idle) -> bool:
    """Whether the semaphore ``idle`` counts a core now (without taking it)."""
    try:
        return idle.get_value() > 0
    except NotImplementedError:  # macOS has no sem_getvalue
        if not idle.acquire(False):
            return False
        idle.release()
        return True


def has_spare_core() -> bool:
    """Whether :func:`beside` would compute its second item in a process of its own now (a
    borrowed core may be taken by another worker before: then :func:`beside` computes both here)."""
    return _SPARE["core"] or (_SPARE["idle"] is not None and _idle_now(_SPARE["idle"]))


def no_spare_core() -> None:
    """Forbid :func:`beside`'s fork in this process from now on (a worker process's first call)."""
    _SPARE["core"], _SPARE["idle"] = False, None


def borrow_idle_cores(idle) -> None:
    """From now on :func:`beside` may borrow a core that ``idle`` counts (a semaphore the
    workers of one map share, released by each worker that found no item left), returning it
    when its child is done: the last fits of a map run on the cores the others left."""
    _SPARE["idle"] = idle if hasattr(os, "fork") else None


def _send(value, pipe: int, memory: int | None) -> None:
    """Pickle ``value`` into the pipe, its arrays' buffers (pickle protocol 5) written into the
    shared ``memory`` file when there is one (one copy, instead of three through the pipe)."""
    buffers: list = []
    data = pickle.dumps(value, protocol=5, buffer_callback=None if memory is None else buffers.append)
    sizes = []
    for buffer in buffers:
        raw = buffer.raw()
        sizes.append(raw.nbytes)
        view = memoryview(raw).cast("B")
        while view.nbytes:
            view = view[os.write(memory, view):]
    with os.fdopen(pipe, "wb") as out:
        out.write(pickle.dumps((data, sizes)))


def _receive(payload: bytes, memory: int | None):
    """The value :func:`_send` sent: its arrays backed by the shared file's pages (no copy)."""
    data, sizes = pickle.loads(payload)
    if not sum(sizes):  # no buffers, or empty ones (a file cannot map zero bytes)
        return pickle.loads(data, buffers=[bytearray()] * len(sizes))
    # private pages (copy on write): a later worker that wrote into an array would not change this process's
    pages = mmap.mmap(memory, sum(sizes), access=mmap.ACCESS_COPY)
    views, start = [], 0
    for size in sizes:
        views.append(memoryview(pages)[start:start + size])
        start += size
    return pickle.loads(data, buffers=views)


def beside(fn: Callable[[Any], Any], items: Sequence) -> list:
    """``[fn(item) for item in items]`` for two items; within :func:`spare_core`, the second
    computed by a forked child while this process computes the first, its result pickled back
    (arrays through a shared memory file where the system has one). The child starts with this
    process's memory (nothing is sent to it) and leaves no trace: an exception it raised is
    raised here, and the child is ended and reaped whatever happens here (an interruption
    included). Each item is computed from the same inputs as in the loop, so the results are the
    loop's, bit for bit, where ``fn`` changes nothing the other item reads."""
    items = list(items)
    if len(items) != 2:
        return [fn(item) for item in items]
    idle = None if _SPARE["core"] else _SPARE["idle"]
    if not _SPARE["core"] and not (idle is not None and idle.acquire(False)):
        return [fn(item) for item in items]
    memory = os.memfd_create("uqdrive-beside") if hasattr(os, "memfd_create") else None
    try:
        return _fork_second(fn, items, memory)
    finally:
        if memory is not None:
            os.close(memory)  # a mapping of it stays valid
        if idle is not None:
            idle.release()  # the borrowed core, for the next batch (of this worker or another)


def _end_with(parent: int) -> None:
    """Have this (forked) process killed when its parent ends (Linux's PR_SET_PDEATHSIG): a
    worker that a map ends by SIGTERM runs no ``finally`` that could end its child."""
    with contextlib.suppress(OSError, AttributeError):
        ctypes.CDLL(None, use_errno=True).prctl(_PR_SET_PDEATHSIG, signal.SIGKILL)
    if os.getppid() != parent:  # the parent ended before the request
        _exit(1)


def _fork_second(fn, items, memory):
    """:func:`beside`'s fork: ``fn(items[1])`` in the child, sent through ``memory`` (or the pipe);
    ``fn(items[0])`` here; the child reaped, or killed and reaped where this side raises."""
    read, write = os.pipe()
    parent = os.getpid()
    pid = os.fork()
    if pid == 0:  # the child: compute, send, end without running the parent's exit handlers
        status = 1
        try:
            os.close(read)
            with contextlib.suppress(ValueError):  # a terminal's Ctrl-C is the parent's to answer
                signal.signal(signal.SIGINT, signal.SIG_IGN)
            _end_with(parent)
            no_spare_core()
            try:
                value = ("ok", fn(items[1]))
            except BaseException as error:  # noqa: BLE001  (raised in the parent)
                value = ("error", error)
            try:
                _send(value, write, memory)
            except Exception as error:  # noqa: BLE001  (an exception or a result that cannot be pickled)
                _send(("error", RuntimeError(f"{type(error).__name__}: {error}")), write, None)
            status = 0
        finally:
            _exit(status)
    os.close(write)
    done = False
    try:
        first = fn(items[0])
        with os.fdopen(read, "rb") as pipe:
            read = None  # the file closes it
            payload = pipe.read()
        os.waitpid(pid, 0)
        done = True
    finally:
        if read is not None:
            os.close(read)
        if not done:
            with contextlib.suppress(ProcessLookupError):
                os.kill(pid, signal.SIGKILL)
            with contextlib.suppress(ChildProcessError):
                os.waitpid(pid, 0)
    if not payload:
        raise RuntimeError("the process computing half of a batch ended without its result (killed?)")
    status, value = _receive(payload, memory)
    if status == "error":
        raise value
    return [first, value]

"""The cores a computation uses: one BLAS thread for the small-matrix kernels, and a forked process
beside this one for half of a batch where the caller has a core to spare (:func:`spare_core`).

OpenBLAS threads make products and solves of tens-by-tens matrices about twice as slow on a
2-core machine; a batch of independent parts (the RK4 passes of a fit's Jacobian) computed on two
cores while the other core would idle takes about half the time.
"""

from __future__ import annotations

import contextlib
import functools
import mmap
import os
import pickle
import signal
from os import _exit
from typing import Any, Callable, Sequence

from threadpoolctl import ThreadpoolController

__all__ = ["beside", "has_spare_core", "no_spare_core", "single_blas_thread", "spare_core", "with_single_blas_thread"]

#: Whether this process may fork one more process now (set by :func:`spare_core`).
_SPARE = {"core": False}


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
    item alone with a worker's core idle. Restores the previous setting on exit."""
    before = _SPARE["core"]
    _SPARE["core"] = bool(spare) and hasattr(os, "fork")
    try:
        yield
    finally:
        _SPARE["core"] = before


def has_spare_core() -> bool:
    """Whether :func:`beside` would compute its second item in a process of its own now."""
    return _SPARE["core"]


def no_spare_core() -> None:
    """Forbid :func:`beside`'s fork in this process from now on (a worker process's first call)."""
    _SPARE["core"] = False


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
    if len(items) != 2 or not _SPARE["core"]:
        return [fn(item) for item in items]
    memory = os.memfd_create("uqdrive-beside") if hasattr(os, "memfd_create") else None
    try:
        return _fork_second(fn, items, memory)
    finally:
        if memory is not None:
            os.close(memory)  # a mapping of it stays valid


def _fork_second(fn, items, memory):
    """:func:`beside`'s fork: ``fn(items[1])`` in the child, sent through ``memory`` (or the pipe);
    ``fn(items[0])`` here; the child reaped, or killed and reaped where this side raises."""
    read, write = os.pipe()
    pid = os.fork()
    if pid == 0:  # the child: compute, send, end without running the parent's exit handlers
        status = 1
        try:
            os.close(read)
            with contextlib.suppress(ValueError):  # a terminal's Ctrl-C is the parent's to answer
                signal.signal(signal.SIGINT, signal.SIG_IGN)
            _SPARE["core"] = False
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

"""SIGINT/SIGTERM/SIGHUP turned into :class:`Interrupted` at a point where raising is safe: never
inside an import, numba's compiler nor a :func:`shielded` block; it is raised once they have ended.

An extension module whose initialisation is interrupted prints the traceback itself and reports
ImportError (numba's does), and a library interrupted between taking a lock and its ``try``
never releases it (netCDF4's writer then waits for it forever): so a signal that lands in an
import or a compilation is raised when a check every :data:`RECHECK` s finds it over (SIGALRM), and one
that lands in a shielded block when the block ends. :func:`uqdrive.cli.main.main` installs the
handlers; this module holds what they share with the outputs.
"""

from __future__ import annotations

import importlib.util
import os
import signal
from contextlib import contextmanager

__all__ = ["Interrupted", "RECHECK", "deliver", "forget_signals", "package_roots", "raise_if_interrupted", "shielded", "signal_received"]

#: Seconds between the checks whether the import a signal landed in has ended.
RECHECK = 0.02


class Interrupted(BaseException):
    """SIGINT/SIGTERM/SIGHUP turned into an exception, so that cleanup runs (like KeyboardInterrupt)."""

    __module__ = "uqdrive.cli.main"

    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = signum


#: Signals the command line's handler received (:func:`signal_received`). Code called back from C
#: swallows the exception (ctypes prints "Exception ignored" and goes on: numba writing its cache
#: is such a callback), so the run would continue and write its outputs; every output checks here
#: (:func:`raise_if_interrupted`) before it is moved into place.
_RECEIVED: list[int] = []
#: Depth of the :func:`shielded` blocks now running, and whether a recheck timer is armed.
_STATE = {"shield": 0, "armed": False}


def signal_received(signum: int) -> None:
    """Record that the run was interrupted by ``signum`` (the command line's signal handler)."""
    _RECEIVED.append(int(signum))


def _disarm() -> None:
    if _STATE["armed"]:
        signal.setitimer(signal.ITIMER_REAL, 0)
        _STATE["armed"] = False


def forget_signals() -> None:
    """Forget the signals received and stop a pending recheck (a command line run ended)."""
    _RECEIVED.clear()
    _disarm()


def raise_if_interrupted() -> None:
    """Raise :class:`Interrupted` if a signal was received whose exception did not end the run
    (the pending recheck is stopped: the exception is raised once)."""
    if _RECEIVED:
        _disarm()
        raise Interrupted(_RECEIVED[0])


def package_roots(*names: str) -> tuple[str, ...]:
    """The folders (each ending in the path separator) of the installed packages ``names``, found
    without importing them; a package not installed has none."""
    roots = []
    for name in names:
        try:
            spec = importlib.util.find_spec(name)
        except (ImportError, ValueError):
            spec = None
        for folder in (spec.submodule_search_locations or ()) if spec is not None else ():
            # as the code's files name it (the folder found on sys.path) and with links resolved
            roots += dict.fromkeys(os.path.join(path, "") for path in (os.path.abspath(folder), os.path.realpath(folder)))
    return tuple(roots)


#: Code a signal's exception must not interrupt, by the file of its code: importlib's bootstrap
#: (an import), and numba's and llvmlite's packages (a compilation or a load from numba's cache:
#: an exception there leaves LLVM's state half-changed, and the interpreter may crash at exit,
#: status -11), by their installed folders, so that a project's own folder named numba is not theirs.
_DEFERRING = {"frozen": "<frozen importlib", "roots": package_roots("numba", "llvmlite")}


def _in_deferring_code(frame) -> bool:
    """Whether ``frame`` runs inside an import or numba's compiler (a frame of their code below it)."""
    frozen, roots = _DEFERRING["frozen"], _DEFERRING["roots"]
    while frame is not None:
        name = frame.f_code.co_filename
        if name.startswith(frozen) or (roots and name.startswith(roots)):
            return True
        frame = frame.f_back
    return False


def deliver(frame, can_recheck: bool) -> None:
    """Raise the received signal's :class:`Interrupted` in ``frame``, the one a handler interrupted,
    unless that is unsafe: in a :func:`shielded` block it is raised when the block ends, in an
    import or numba's compiler (with ``can_recheck``: SIGALRM's handler calls this again) after a recheck."""
    if not _RECEIVED:
        return
    if _STATE["shield"]:
        return
    if can_recheck and _in_deferring_code(frame):
        _STATE["armed"] = True
        signal.setitimer(signal.ITIMER_REAL, RECHECK)
        return
    raise_if_interrupted()


@contextmanager
def shielded():
    """A block a signal's exception does not interrupt: it is raised when the block ends (a
    library's own locking, such as a netCDF write, runs whole)."""
    _STATE["shield"] += 1
    try:
        yield
    finally:
        _STATE["shield"] -= 1
    if not _STATE["shield"]:
        raise_if_interrupted()

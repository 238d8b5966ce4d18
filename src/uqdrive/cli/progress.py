"""Progress of the long commands: one line per stage on stderr with the seconds since the start,
when stderr is a terminal (a refusal in a pipeline stays one line) and not silenced by ``--quiet``."""

from __future__ import annotations

import sys
import time
from typing import TextIO

__all__ = ["Progress", "is_terminal"]


def is_terminal(stream) -> bool:
    """Whether ``stream`` is an interactive terminal (where progress lines belong)."""
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):  # closed or not a real file
        return False


class Progress:
    """A stage logger: ``progress("fitting")`` writes ``uqdrive: [   1.2 s] fitting`` to ``stream``.

    Parameters
    ----------
    quiet : bool
        Write nothing.
    stream : file, optional
        Where the lines go (default: ``sys.stderr`` at the time of each call); a stream that is
        not a terminal gets them only when it is given here.
    """

    def __init__(self, quiet: bool = False, stream: TextIO | None = None):
        self.quiet = quiet
        self.stream = stream
        self.start = time.perf_counter()

    def _target(self) -> TextIO | None:
        if self.quiet:
            return None
        if self.stream is not None:
            return self.stream
        return sys.stderr if is_terminal(sys.stderr) else None

    def elapsed(self) -> float:
        """Seconds since this logger was made."""
        return time.perf_counter() - self.start

    def __call__(self, stage: str) -> None:
        stream = self._target()
        if stream is None:
            return
        stream.write(f"uqdrive: [{self.elapsed():6.1f} s] {stage.removeprefix('discover: ')}\n")
        stream.flush()

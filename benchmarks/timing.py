"""Timing helper shared by the benchmark scripts (run as `python benchmarks/<script>.py`)."""

from __future__ import annotations

import time


def best_of(fn, repeats: int = 3):
    """Smallest wall time of ``repeats`` calls of ``fn`` (s) and the last result: the minimum is
    the least disturbed by other processes and by first-call costs."""
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return min(times), out

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


#: An output's clock readings: they differ between two runs of the same computation.
CLOCK_KEYS = ("seconds", "stage_seconds")


def without(v, keys=CLOCK_KEYS):
    """``v`` (nested dicts and lists, as a verdict or a table's rows) without the dict entries
    named in ``keys``, so that two runs' outputs compare number for number."""
    if isinstance(v, dict):
        return {k: without(x, keys) for k, x in v.items() if k not in keys}
    return [without(x, keys) for x in v] if isinstance(v, list) else v

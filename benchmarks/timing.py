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


def report_compiled(rows, args, command: str, width: int) -> None:
    """Print the rows of a compiled-against-NumPy benchmark (per call in us, a discover in CPU s)
    and write its record to ``args.json`` where given."""
    import json

    print(f"{'case':<{width}}{'numpy':>12}{'compiled':>12}{'ratio':>8}  same bits")
    for r in rows:
        unit = 1e6 if r["case"].startswith("rhs") else 1.0
        print(f"{r['case']:<{width}}{r['numpy_s'] * unit:>12.2f}{r['compiled_s'] * unit:>12.2f}{r['ratio']:>8.2f}  {r['same']}")
    if args.json:
        record = {"command": command, "machine": args.machine, "repeats": args.repeats, "rows": rows}
        with open(args.json, "w") as fh:
            json.dump(record, fh, indent=1)


def per_call(rhs, x, repeats: int, calls: int):
    """Seconds per call of a right-hand side ``rhs(x, j, out)`` at half step 3, best of ``repeats``
    x ``calls`` after one call that compiles or loads its loops, and the rates it wrote."""
    import numpy as np

    out = np.empty_like(x)
    rhs(x, 3, out)

    def run():
        for _ in range(calls):
            rhs(x, 3, out)
        return out.copy()

    seconds, rates = best_of(run, repeats)
    return seconds / calls, rates


def moved(old, new, path="", rtol=1e-6):
    """(path, old, new) of every number of ``new`` that differs from ``old`` by more than ``rtol``
    relative (``rtol`` 0: any difference; NaN equals NaN), and of every other value that differs
    (a name, a structure)."""
    if isinstance(old, dict) and isinstance(new, dict):
        return [m for k in sorted(set(old) | set(new)) for m in moved(old.get(k), new.get(k), f"{path}.{k}", rtol)]
    if isinstance(old, list) and isinstance(new, list) and len(old) == len(new):
        return [m for i, (a, b) in enumerate(zip(old, new)) for m in moved(a, b, f"{path}[{i}]", rtol)]
    numbers = all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in (old, new))
    if numbers and (abs(old - new) <= rtol * max(abs(old), abs(new), 1e-300) or (old != old and new != new)):  # NaN on both sides: not moved
        return []
    return [] if not numbers and old == new else [(path, old, new)]


def record_arguments(ap) -> None:
    """``--json FILE`` (where to write the record) and ``--machine TEXT`` (the record's machine,
    in words; default: the architecture and Python version) on the parser ``ap``."""
    import platform

    ap.add_argument("--json", help="write the record here")
    ap.add_argument("--machine", default=f"{platform.machine()} machine, Python {platform.python_version()}", help="the record's machine, in words")


def discover_cpu(module, fused: bool, runs, **kwargs):
    """CPU seconds of ``uqdrive.discover(runs, **kwargs)`` with ``module.FUSED`` set to ``fused``
    (restored to True after) and the verdict as a dict."""
    import uqdrive

    module.FUSED = fused
    try:
        t0 = time.process_time()
        verdict = uqdrive.discover(runs, **kwargs)
        return time.process_time() - t0, verdict.to_dict()
    finally:
        module.FUSED = True

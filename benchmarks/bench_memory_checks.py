"""Benchmark: the compiled chassis loops within uqdrive's limit of LLVM's runtime alias checks
(uqdrive.vehicle.dynamics.jit.MEMORY_CHECKS) against LLVM's own limits (the baseline, in the same run).

Each variant runs in processes of its own, with a numba cache of its own (every loop compiled
anew under its limits):

1. one right-hand-side call per chassis term of benchmarks/bench_fused_chassis.py (the Magic
   Formula's and the linear tyre's) at 300 and 2400 realisations, best of ``--repeats`` x 300
   calls, and whether the two variants' rates are equal bit for bit;
2. ``uqdrive discover --jobs N`` on each ``--case`` (fw_slalom_090 of docs/four_wheel.md by
   default; ``tour`` or another four-wheel case), after an untimed discover of the case's first
   60 runs that compiles the loops: wall and CPU seconds (the command and its workers), and
   whether the two verdict.json files are equal number for number (their clock readings aside).

    python benchmarks/bench_memory_checks.py [--repeats 3] [--jobs 2] [--case NAME ...] [--no-discover] [--json FILE] [--machine TEXT]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from timing import moved, record_arguments, without

#: LLVM's own limits on a loop's runtime alias checks (its options' defaults).
LLVM_LIMITS = {"runtime-memory-check-threshold": 8, "vectorize-memory-check-threshold": 128}


def _limits(variant: str) -> None:
    """Set the variant's limits in this process: uqdrive's (its import sets them) or LLVM's own."""
    import llvmlite.binding as llvm

    import uqdrive.vehicle.dynamics.jit  # noqa: F401  (sets uqdrive's)

    if variant == "llvm":
        for option, value in LLVM_LIMITS.items():
            llvm.set_option("bench", f"--{option}={value}")


def _child_calls(repeats: int, out: Path) -> None:
    """Per-call seconds of every chassis term (a JSON list) and the rates (an .npz beside it)."""
    from bench_fused_chassis import TERMS, _calls

    rows, rates = [], {}
    for terms in TERMS:
        for n in (300, 2400):
            seconds, x = _calls(terms, n, True, repeats)
            case = f"rhs call, {' + '.join(terms).replace('linear + ', 'linear tyre: ')}, {n} realisations"
            rows.append({"case": case, "seconds": seconds})
            rates[str(len(rates))] = x
    out.write_text(json.dumps(rows))
    np.savez(out.with_suffix(".npz"), **rates)


def _child(argv: list[str]) -> int:
    variant, what, *rest = argv
    _limits(variant)
    if what == "calls":
        _child_calls(int(rest[0]), Path(rest[1]))
        return 0
    from uqdrive.cli.main import main

    return main([what, *rest])


def _run(variant: str, cache: Path, args: list[str]) -> tuple[float, float]:
    """Wall and CPU seconds (the process and its workers) of a child of this script."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache)}
    before, t0 = resource.getrusage(resource.RUSAGE_CHILDREN), time.perf_counter()
    subprocess.run([sys.executable, __file__, "--child", variant, *args], check=True, capture_output=True, env=env)
    wall, after = time.perf_counter() - t0, resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] == ["--child"]:
        return _child(argv[1:])
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--case", action="append", help="a four-wheel case or tour (repeatable; default fw_slalom_090)")
    ap.add_argument("--no-discover", action="store_true")
    record_arguments(ap)
    args = ap.parse_args(argv)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        caches = {v: folder / f"numba_{v}" for v in ("llvm", "uqdrive")}
        calls = {}
        for variant, cache in caches.items():
            out = folder / f"calls_{variant}.json"
            _run(variant, cache, ["calls", str(args.repeats), str(out)])
            calls[variant] = (json.loads(out.read_text()), np.load(out.with_suffix(".npz")))
        for k, (old, new) in enumerate(zip(calls["llvm"][0], calls["uqdrive"][0])):
            same = bool(np.array_equal(calls["llvm"][1][str(k)], calls["uqdrive"][1][str(k)]))
            rows.append({"case": old["case"], "llvm_s": old["seconds"], "uqdrive_s": new["seconds"], "ratio": old["seconds"] / new["seconds"],
                         "same": same})
        for case in [] if args.no_discover else args.case or ["fw_slalom_090"]:
            from bench_discover_jobs import _inputs

            inputs = _inputs(case, folder)
            import xarray as xr

            from uqdrive.io import write_dataset

            with xr.open_dataset(inputs[0]) as runs:
                write_dataset(runs.isel(sample=slice(0, 60)).load(), folder / "warm.nc")
            timed = {}
            for variant, cache in caches.items():
                out = folder / f"{case}_{variant}"
                common = ["discover", *inputs[1:], "--jobs", str(args.jobs), "--no-figures", "--quiet", "--force"]
                _run(variant, cache, [*common[:1], str(folder / "warm.nc"), *common[1:], "--out", str(folder / "warm")])
                wall, cpu = _run(variant, cache, [*common[:1], inputs[0], *common[1:], "--out", str(out)])
                timed[variant] = (wall, cpu, json.loads((out / "verdict.json").read_text()))
            (w0, c0, v0), (w1, c1, v1) = timed["llvm"], timed["uqdrive"]
            rows.append({"case": f"discover, {case}, every candidate, --jobs {args.jobs} (wall s)", "llvm_s": w0, "uqdrive_s": w1,
                         "ratio": w0 / w1, "same": not moved(without(v0), without(v1), rtol=0.0),
                         "moved": [path for path, _, _ in moved(without(v0), without(v1), rtol=0.0)],
                         "cpu_llvm_s": c0, "cpu_uqdrive_s": c1})
    print(f"{'case':<80}{'LLVM limits':>13}{'uqdrive':>10}{'ratio':>8}  same")
    for r in rows:
        unit = 1e6 if r["case"].startswith("rhs") else 1.0
        print(f"{r['case']:<80}{r['llvm_s'] * unit:>13.2f}{r['uqdrive_s'] * unit:>10.2f}{r['ratio']:>8.2f}  {r['same']}"
              + (f"   CPU s {r['cpu_llvm_s']:.1f} -> {r['cpu_uqdrive_s']:.1f}" if "cpu_llvm_s" in r else ""))
    if args.json:
        record = {"command": "python benchmarks/bench_memory_checks.py", "machine": args.machine, "repeats": args.repeats, "jobs": args.jobs,
                  "llvm_limits": LLVM_LIMITS, "rows": rows}
        Path(args.json).write_text(json.dumps(record, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""Benchmark: `uqdrive discover --jobs N` (the fits of each search step on N forked workers)
against one process (the baseline, in the same run), as a user runs it from the command line.

Each ``--case`` is run with ``--jobs 1`` and then ``--jobs N``: wall seconds, CPU seconds of the
command and its workers, and whether the two verdict.json files are equal number for number
(their clock readings aside). Cases: ``tour`` (the README tour's 200 NLST runs, every candidate,
the posterior as configured) and the four-wheel cases of docs/four_wheel.md (500 runs of the
independent four-wheel car, every candidate, no posterior), fw_step_030 by default.

    python benchmarks/bench_discover_jobs.py [--jobs 2] [--case NAME ...] [--json FILE [--merge]] [--machine TEXT]

``--merge`` keeps the rows of other cases already in ``--json`` (a case run again replaces its
row), in the order tour, then the four-wheel cases as uqdrive.studies.four_wheel lists them. The
record in docs/measurements/benchmarks_discover_jobs.json has the tour and every four-wheel case
(--case tour --case fw_step_030 --case fw_slalom_090, then the other four with --merge, on one
machine and day), numba's cache filled beforehand by untimed discovers of 60 runs of each case.
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

import yaml

from bench_fused_chassis import four_wheel_case
from timing import record_arguments, without

from uqdrive.io import write_dataset


def _inputs(case: str, folder: Path) -> list[str]:
    """The discover arguments of ``case`` (its data and config written into ``folder``)."""
    data, config = folder / f"{case}.nc", folder / f"{case}.yaml"
    if case == "tour":
        subprocess.run([sys.executable, "-m", "uqdrive.cli.main", "simulate", "--model", "nlst", "--samples", "200", "--out", str(data)],
                       check=True, capture_output=True)
        return [str(data)]
    runs, cfg = four_wheel_case(case)
    write_dataset(runs, data)
    config.write_text(yaml.safe_dump(cfg))
    return [str(data), "--config", str(config), "--candidates", "all", "--no-posterior"]


def _discover(args: list[str], out: Path, jobs: int) -> tuple[float, float, dict]:
    """Wall and CPU seconds (the command and its workers) of one discover, and its verdict."""
    before, t0 = resource.getrusage(resource.RUSAGE_CHILDREN), time.perf_counter()
    subprocess.run([sys.executable, "-m", "uqdrive.cli.main", "discover", *args, "--out", str(out), "--jobs", str(jobs),
                    "--no-figures", "--quiet", "--force"], check=True, capture_output=True)
    wall, after = time.perf_counter() - t0, resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)
    return wall, cpu, json.loads((out / "verdict.json").read_text())


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--case", action="append", help="tour or a four-wheel case (repeatable; default tour and fw_step_030)")
    record_arguments(ap)
    ap.add_argument("--merge", action="store_true", help="keep the rows of other cases already in --json")
    args = ap.parse_args(argv)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        for case in args.case or ["tour", "fw_step_030"]:
            inputs = _inputs(case, folder)
            one = _discover(inputs, folder / f"{case}_1", 1)
            many = _discover(inputs, folder / f"{case}_{args.jobs}", args.jobs)
            rows.append({"case": case, "jobs": args.jobs, "wall_1_s": round(one[0], 1), "cpu_1_s": round(one[1], 1),
                         "wall_n_s": round(many[0], 1), "cpu_n_s": round(many[1], 1), "same": without(one[2]) == without(many[2])})
            r = rows[-1]
            print(f"{case:<14} 1 process {r['wall_1_s']:7.1f} s ({r['cpu_1_s']:.1f} CPU-s)   {args.jobs} workers {r['wall_n_s']:7.1f} s "
                  f"({r['cpu_n_s']:.1f} CPU-s)   {r['wall_1_s'] / r['wall_n_s']:.2f}x   same verdict: {r['same']}", flush=True)
    if args.json:
        if args.merge and Path(args.json).exists():
            rows = _merged(json.loads(Path(args.json).read_text())["rows"], rows)
        record = {"command": "python benchmarks/bench_discover_jobs.py", "machine": args.machine,
                  "cpus": len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count(), "rows": rows}
        Path(args.json).write_text(json.dumps(record, indent=1) + "\n")
    return 0


def _merged(old: list, new: list) -> list:
    """The rows of ``old`` and ``new`` by case (``new`` replacing a case of ``old``), the tour
    first, then the four-wheel cases in the order of uqdrive.studies.four_wheel."""
    from uqdrive.config import load_config
    from uqdrive.studies.four_wheel import four_wheel_cases

    order = ["tour"] + [c.name for c in four_wheel_cases(load_config(None))]
    rows = {r["case"]: r for r in old} | {r["case"]: r for r in new}
    return sorted(rows.values(), key=lambda r: order.index(r["case"]) if r["case"] in order else len(order))


if __name__ == "__main__":
    raise SystemExit(main())

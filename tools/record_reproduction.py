#!/usr/bin/env python
"""Record where a finished ``make reproduce`` spent its time into docs/measurements/benchmarks_reproduction.json,
which docs/benchmarks.md renders: per rule, from Snakemake's benchmark files, and the scorecard's counts.

    .venv/bin/python tools/record_reproduction.py RESULTS_DIR --wall-s 1320 --machine "idle 2-core machine" [--json PATH]

``RESULTS_DIR``: the run's ``results/`` (its ``benchmarks/RULE/*.tsv`` and ``scorecard.csv``).
"""

from __future__ import annotations

import argparse
import collections
import csv
import json
import re
from pathlib import Path

from uqdrive.outputs import atomic_path

TOP = 8  # rules listed one by one; the rest summed


def rule_times(results: Path) -> dict:
    """{rule: [jobs, job-seconds, longest job (s), CPU-seconds]} from ``results/benchmarks/RULE/*.tsv``."""
    out = collections.defaultdict(lambda: [0, 0.0, 0.0, 0.0])
    for tsv in sorted((results / "benchmarks").glob("*/*.tsv")):
        with tsv.open() as f:
            row = next(csv.DictReader(f, delimiter="\t"))
        s, cpu = float(row["s"]), float(row.get("cpu_time") or 0.0)
        r = out[tsv.parent.name]
        r[0] += 1
        r[1] += s
        r[2] = max(r[2], s)
        r[3] += cpu
    return dict(out)


def scorecard_counts(path: Path) -> dict:
    with path.open() as f:
        status = [row["status"] for row in csv.DictReader(f)]
    return {"rows": len(status), "pass": status.count("pass"), "deviate": status.count("deviates"), "fail": status.count("fail")}


def dag_steps(results: Path) -> int | None:
    """The DAG's steps (its jobs, the target rule included) from the run's newest Snakemake log that finished one."""
    logs = sorted((results.parent / ".snakemake" / "log").glob("*.snakemake.log"), reverse=True)
    for log in logs:
        done = re.findall(r"^(\d+) of \1 steps \(100%\) done", log.read_text(errors="replace"), re.M)
        if done:
            return int(done[-1])
    return None


def record(results: Path, wall_s: float, machine: str, command: str) -> dict:
    times = rule_times(results)
    ranked = sorted(times.items(), key=lambda kv: -kv[1][1])
    top, rest = ranked[:TOP], ranked[TOP:]
    return {
        "command": command,
        "machine": machine,
        "date": None,
        "wall_s": round(wall_s),
        "dag_jobs": dag_steps(results) or sum(v[0] for v in times.values()),
        "job_seconds": round(sum(v[1] for v in times.values())),
        "cpu_seconds": round(sum(v[3] for v in times.values())),
        "scorecard": scorecard_counts(results / "scorecard.csv"),
        "rules": [{"rule": k, "jobs": v[0], "job_seconds": round(v[1]), "longest_s": round(v[2]), "cpu_seconds": round(v[3])} for k, v in top],
        "other_rules": {"rules": len(rest), "jobs": sum(v[0] for _, v in rest), "job_seconds": round(sum(v[1] for _, v in rest))},
    }


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("results", type=Path)
    ap.add_argument("--wall-s", type=float, required=True, help="the run's wall time from the clone to the report (s)")
    ap.add_argument("--machine", required=True)
    ap.add_argument("--command", default="make reproduce from a clean clone (venv included)")
    ap.add_argument("--json", type=Path, default=Path(__file__).resolve().parents[1] / "docs/measurements/benchmarks_reproduction.json")
    a = ap.parse_args(argv)
    rec = record(a.results, a.wall_s, a.machine, a.command)
    with atomic_path(a.json) as tmp:
        tmp.write_text(json.dumps(rec, indent=1) + "\n")
    print(f"{a.json}: {rec['dag_jobs']} jobs, {rec['job_seconds']} job-s, {rec['cpu_seconds']} CPU-s, wall {rec['wall_s']} s")


if __name__ == "__main__":
    main()

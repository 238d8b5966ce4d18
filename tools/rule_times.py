#!/usr/bin/env python
"""Where a Snakemake run's time went: per rule, the jobs, their summed and longest wall times,
read from the run's log (``.snakemake/log/*.snakemake.log``, the newest one by default).

    .venv/bin/python tools/rule_times.py                      # newest log of this folder
    .venv/bin/python tools/rule_times.py path/to/x.snakemake.log --top 15

Prints a Markdown table and the run's span (docs/benchmarks.md's record of a finished run is written by
tools/record_reproduction.py from the benchmark files instead). A job's
time runs from the timestamp before its "rule X:" block to the one before "Finished jobid: N";
group jobs are listed under their member rules, as Snakemake logs them.
"""

from __future__ import annotations

import argparse
import collections
import datetime as dt
import re
import sys
from pathlib import Path

_STAMP = re.compile(r"^\[(\w{3} \w{3}\s+\d+ \d\d:\d\d:\d\d \d{4})\]")
_RULE = re.compile(r"^(?:local)?(?:rule|checkpoint) (\S+):\s*$")
_JOBID = re.compile(r"^\s+jobid: (\d+)")
_DONE = re.compile(r"^Finished jobid: (\d+)")


def job_times(lines):
    """(rule, start, end) of every finished job in a Snakemake log."""
    now, rule, started, out = None, None, {}, []
    for line in lines:
        if m := _STAMP.match(line):
            now = dt.datetime.strptime(" ".join(m.group(1).split()), "%a %b %d %H:%M:%S %Y")
        elif m := _RULE.match(line):
            rule = m.group(1)
        elif (m := _JOBID.match(line)) and rule is not None:
            started[m.group(1)] = (rule, now)
            rule = None
        elif (m := _DONE.match(line)) and m.group(1) in started:
            name, start = started.pop(m.group(1))
            out.append((name, start, now))
    return out


def table(jobs, top: int | None = None) -> str:
    per_rule = collections.defaultdict(list)
    for name, start, end in jobs:
        per_rule[name].append((end - start).total_seconds())
    rows = sorted(per_rule.items(), key=lambda kv: -sum(kv[1]))
    total = sum(sum(t) for _, t in rows)
    lines = ["| rule | jobs | job-seconds | share | longest job (s) |", "|---|---:|---:|---:|---:|"]
    shown = rows if top is None else rows[:top]
    for name, times in shown:
        lines.append(f"| {name} | {len(times)} | {sum(times):.0f} | {100 * sum(times) / total:.0f} % | {max(times):.0f} |")
    if len(shown) < len(rows):
        rest = rows[len(shown):]
        s = sum(sum(t) for _, t in rest)
        lines.append(f"| {len(rest)} other rules | {sum(len(t) for _, t in rest)} | {s:.0f} | {100 * s / total:.0f} % | |")
    span = (max(e for *_, e in jobs) - min(s for _, s, _ in jobs)).total_seconds()
    lines.append(f"| **all** | {len(jobs)} | {total:.0f} | | span {span // 60:.0f} min {span % 60:.0f} s |")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("log", nargs="?", type=Path, help="a Snakemake log (default: the newest in .snakemake/log)")
    ap.add_argument("--top", type=int, default=None, help="rules shown (the rest summed in one row)")
    args = ap.parse_args(argv)
    log = args.log
    if log is None:
        logs = sorted(Path(".snakemake/log").glob("*.snakemake.log"))
        if not logs:
            print("no Snakemake log in .snakemake/log: run the workflow first or name a log", file=sys.stderr)
            return 2
        log = logs[-1]
    jobs = job_times(log.read_text().splitlines())
    if not jobs:
        print(f"{log}: no finished jobs", file=sys.stderr)
        return 2
    print(table(jobs, args.top))
    return 0


if __name__ == "__main__":
    sys.exit(main())

#!/usr/bin/env python
"""Each rule's declared resources (``mem_mb``, ``runtime`` in workflow/rules/*.smk) against what its
jobs used (the ``benchmark:`` files every rule writes: Snakemake's max_rss and wall time per job).

A group job on Slurm runs all its rules in one step, so ``sacct`` sees only the group's peak; the
benchmark files, written by the group job's own Snakemake, give each rule's. Usage::

    .venv/bin/python tools/rule_resources.py results            # table; exit 1 if a rule used more
    .venv/bin/python tools/rule_resources.py results --suggest  # plus declarations with the margin

Several run folders may be given (e.g. the CI-sized and the full config's); a rule's peak is the
largest over all of them. tests/test_slurm.py runs :func:`over_declared` on the CI-sized run on Slurm.
"""

from __future__ import annotations

import argparse
import csv
import math
import re
import sys
from pathlib import Path

RULES = Path(__file__).resolve().parents[1] / "workflow" / "rules"
#: Declarations proposed by --suggest: the measured peak times these margins (memory grows with
#: the config's sizes and a node's other jobs; wall time with a loaded node), rounded up.
MEMORY_MARGIN, RUNTIME_MARGIN = 1.5, 3.0


def declared(rules_dir: Path = RULES) -> dict[str, tuple[float, float]]:
    """{rule: (mem_mb, runtime in minutes)} as the rules of ``rules_dir`` declare them."""
    found = {}
    for path in sorted(rules_dir.glob("*.smk")):
        for name, body in re.findall(r"^rule (\w+):\n((?:[ \t]+.*\n|\n)*)", path.read_text(), re.MULTILINE):
            mem, runtime = re.search(r"mem_mb=(\d+)", body), re.search(r"runtime=(\d+)", body)
            if mem and runtime:
                found[name] = (float(mem.group(1)), float(runtime.group(1)))
    return found


def measured(*folders: Path) -> dict[str, dict[str, float]]:
    """{rule: {"max_rss": MB, "seconds": s, "jobs": n}}: the largest over the benchmark files
    ``*/benchmarks/RULE/*.tsv`` below the given run folders (one row per job)."""
    peaks: dict[str, dict[str, float]] = {}
    for folder in folders:
        for path in sorted(Path(folder).rglob("benchmarks/*/*.tsv")):
            with path.open() as fh:
                rows = list(csv.DictReader(fh, delimiter="\t"))
            for row in rows:
                peak = peaks.setdefault(path.parent.name, {"max_rss": 0.0, "seconds": 0.0, "jobs": 0})
                rss = float(row["max_rss"]) if row.get("max_rss", "NA") not in ("NA", "-", "") else 0.0
                peak["max_rss"] = max(peak["max_rss"], rss)
                peak["seconds"] = max(peak["seconds"], float(row["s"]))
                peak["jobs"] += 1
    return peaks


def suggest(peak: dict[str, float]) -> tuple[int, int]:
    """(mem_mb, runtime in minutes) for a rule with this peak: the margins above, memory rounded
    up to 500 MB (at least 1000), runtime to whole minutes (at least 2)."""
    mem = max(1000, 500 * math.ceil(peak["max_rss"] * MEMORY_MARGIN / 500))
    runtime = max(2, math.ceil(peak["seconds"] * RUNTIME_MARGIN / 60))
    return mem, runtime


def over_declared(peaks: dict[str, dict[str, float]], declarations: dict[str, tuple[float, float]]) -> list[str]:
    """Rules whose jobs used more memory or time than the rule declares (one line each)."""
    over = []
    for rule, peak in sorted(peaks.items()):
        if rule not in declarations:
            over.append(f"{rule}: no mem_mb/runtime declared")
            continue
        mem, runtime = declarations[rule]
        if peak["max_rss"] > mem or peak["seconds"] > 60 * runtime:
            over.append(f"{rule}: used {peak['max_rss']:.0f} MB and {peak['seconds']:.0f} s, declares {mem:.0f} MB and {runtime:.0f} min")
    return over


def table(peaks, declarations, with_suggestion=False) -> str:
    """The comparison as aligned text, one rule per line."""
    head = f"{'rule':<28} {'jobs':>4} {'peak MB':>8} {'declared':>8} {'peak s':>7} {'declared':>8}"
    lines = [head + ("  suggested" if with_suggestion else "")]
    for rule, peak in sorted(peaks.items()):
        mem, runtime = declarations.get(rule, (float("nan"), float("nan")))
        line = f"{rule:<28} {peak['jobs']:>4} {peak['max_rss']:>8.0f} {mem:>8.0f} {peak['seconds']:>7.1f} {60 * runtime:>8.0f}"
        if with_suggestion:
            line += "  mem_mb={}, runtime={}".format(*suggest(peak))
        lines.append(line)
    return "\n".join(lines)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("folders", nargs="+", type=Path, help="run folders (their results/benchmarks are read)")
    parser.add_argument("--suggest", action="store_true", help="add the declarations the margins give")
    args = parser.parse_args(argv)
    peaks = measured(*args.folders)
    if not peaks:
        print(f"no benchmark files below {', '.join(map(str, args.folders))}: run the workflow there first", file=sys.stderr)
        return 2
    declarations = declared()
    print(table(peaks, declarations, args.suggest))
    over = over_declared(peaks, declarations)
    if over:
        print("\nused more than declared:\n" + "\n".join(over))
    return 1 if over else 0


if __name__ == "__main__":
    sys.exit(main())

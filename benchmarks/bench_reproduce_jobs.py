"""Representative jobs of the reproduction's two discrepancy rules, old against new in one run: a
benchmark discover (rule discrepancy_discover) and a detection-table cell (rule
discrepancy_channel_cell) whose fits move a steering lag or delay beside a Magic-Formula tyre.

"old": the difference neighbours of a fitted lag or delay with a Magic-Formula tyre simulated
pair by pair (a call of their own each, the pass a few hundred realisations wide); "new": one
RK4 pass for them, each pair steered by its own angle (`AugmentedSimulator.simulate_many`). The
jobs run as the workflow runs them (config/config.yaml; the case's ensemble made by
`studies.hidden_effects.generate`, the cell by `studies.discrepancy.channel_detection_cell`);
the two variants alternate in one process, the old one first, after an untimed warm-up discover
(imports, caches), and their outputs must be equal
number for number (verdict.json less its clock readings; the cell's row less its seconds).

Usage: python benchmarks/bench_reproduce_jobs.py [--jobs discover:combined_saturation_lag cell:actuator_lag_200ms:imu_speed:20]
       [--json docs/measurements/benchmarks_reproduce_jobs.json]
"""

import argparse
import json
import os
import platform
import time
from pathlib import Path

from uqdrive.config import load_config
from uqdrive.vehicle.augmented import AugmentedSimulator

CONFIG = Path(__file__).resolve().parents[1] / "config" / "config.yaml"
DEFAULT_JOBS = ("discover:combined_saturation_lag", "cell:actuator_lag_200ms:imu_speed:20")


def _strip(v):
    """An output without its clock readings."""
    if isinstance(v, dict):
        return {k: _strip(x) for k, x in v.items() if k not in ("seconds", "stage_seconds")}
    return [_strip(x) for x in v] if isinstance(v, list) else v


class PairByPair:
    """Within the block, the steering neighbours are simulated by a call of their own each."""

    def __enter__(self):
        self.original = original = AugmentedSimulator._in_passes

        def in_passes(sim, thetas, structures, kind, per_pass=None, **options):
            if options.get("per_pair_input"):
                return [sim.simulate(th, s) for th, s in zip(thetas, structures)]
            return original(sim, thetas, structures, kind, per_pass, **options)

        AugmentedSimulator._in_passes = in_passes
        return self

    def __exit__(self, *exc):
        AugmentedSimulator._in_passes = self.original


def run_job(config, job: str):
    """CPU seconds and output of one job, ``discover:CASE`` or ``cell:CASE:SET:RUNS``."""
    from uqdrive.cli.discover import discover_dataset
    from uqdrive.studies.discrepancy import channel_detection_cell
    from uqdrive.studies.hidden_effects import benchmark_cases, generate

    kind, name, *cell = job.split(":")
    if kind == "discover":
        case = {c.name: c for c in benchmark_cases(config, samples=config["discrepancy"]["benchmark"]["samples"])}[name]
        data = generate(config, case)
        clock = time.process_time()
        _, verdict = discover_dataset(config, data, name)
        return time.process_time() - clock, _strip(verdict)
    case = {c.name: c for c in benchmark_cases(config)}[name]
    clock = time.process_time()
    rows = channel_detection_cell(config, [case], cell[0], int(cell[1]))
    return time.process_time() - clock, _strip(rows)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--jobs", nargs="+", default=list(DEFAULT_JOBS), help="discover:CASE or cell:CASE:SET:RUNS")
    parser.add_argument("--json", type=Path, help="write the record here")
    args = parser.parse_args(argv)
    config = load_config(CONFIG)
    run_job(config, "discover:none_step_held")  # untimed: the first discover's imports and caches would fall on the old variant
    rows = []
    for job in args.jobs:
        with PairByPair():
            old, out_old = run_job(config, job)
        new, out_new = run_job(config, job)
        verdict = out_new["effect"] if isinstance(out_new, dict) else out_new[0]["verdict"]
        rows.append({"job": job, "verdict": verdict, "old_cpu_s": round(old, 1), "new_cpu_s": round(new, 1), "equal": out_old == out_new})
        print(f"{job}: old {old:.1f} CPU-s, new {new:.1f} CPU-s ({old / new:.2f}x), verdict {verdict}, equal: {out_old == out_new}", flush=True)
    record = {"command": "python benchmarks/bench_reproduce_jobs.py", "machine": f"{platform.machine()}, {os.cpu_count()} cores, load "
              f"{os.getloadavg()[0]:.1f} at the end", "rows": rows}
    if args.json:
        args.json.write_text(json.dumps(record, indent=1) + "\n")
    if not all(r["equal"] for r in rows):
        raise SystemExit("the new variant's outputs differ from the old one's")


if __name__ == "__main__":
    main()

"""`discover` with and without the simulations its fits share (``SimulationMemo``): CPU seconds,
calls of the simulator and the verdict of each, on cells of the detection table by channel
set and run count and on benchmark cases at the benchmark's run count (the workflow's
``discrepancy_channel_cell`` and ``discrepancy_discover`` jobs, without the emcee posterior).

The two variants alternate, ``--repeats`` times each, in one process after one untimed discover
(imports, first-call costs); CPU seconds are the smallest of the repeats (other processes on the
machine slow both alike). The verdicts must be
equal, number for number: the memo only hands a fit the array another fit simulated.

Usage: python benchmarks/bench_discover_memo.py [--cells road_bank_3deg:all:40,...] [--repeats 2]
"""

import argparse
import dataclasses
import json
import time
from pathlib import Path

from timing import without
from uqdrive.config import load_config
from uqdrive.inference.discrepancy import DiscrepancyFinder
from uqdrive.inference.discrepancy import finder as finder_module
from uqdrive.studies.discrepancy import BRAKING, CHANNEL_SETS
from uqdrive.studies.hidden_effects import benchmark_cases, generate
from uqdrive.vehicle.augmented import AugmentedSimulator

CELLS = "none_step:imu:20,road_bank_3deg:all:40,tyre_saturation_5deg:imu_speed:100,actuator_delay_50ms:all:1000"


def run(config, data, memo: bool):
    """CPU seconds, calls of AugmentedSimulator.simulate and the verdict of one discover."""
    calls = [0]
    simulate = AugmentedSimulator.simulate

    def counted(self, *args, **kwargs):
        calls[0] += 1
        return simulate(self, *args, **kwargs)

    AugmentedSimulator.simulate = counted
    finder_module.SimulationMemo = original if memo else (lambda: None)
    try:
        clock = time.process_time()
        verdict = DiscrepancyFinder(config, posterior=False).fit(data).verdict_
        return time.process_time() - clock, calls[0], without(verdict)
    finally:
        AugmentedSimulator.simulate = simulate
        finder_module.SimulationMemo = original


original = finder_module.SimulationMemo


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--cells", default=CELLS, help="case:channel_set:runs, comma separated")
    parser.add_argument("--repeats", type=int, default=2)
    args = parser.parse_args(argv)
    config = load_config(Path(__file__).resolve().parents[1] / "config" / "config.yaml")  # the reproduction's candidates
    cases = {c.name: c for c in benchmark_cases(config)}
    rows, warm = [], False
    for cell in args.cells.split(","):
        name, channel_set, runs = cell.split(":")
        channels, braking = CHANNEL_SETS[channel_set]
        data = generate(config, dataclasses.replace(cases[name], samples=int(runs), speed=BRAKING if braking else {}), channels=channels)
        if not warm:  # the first discover of a process pays its imports and first-call costs: untimed
            warm = bool(run(config, data, True))
        best = {}
        for _ in range(args.repeats):
            for memo in (False, True):
                cpu, sims, verdict = run(config, data, memo)
                if memo in best and verdict != best[memo][2]:
                    raise SystemExit(f"{cell}: two runs of one variant disagree")
                best[memo] = min(best.get(memo, (cpu, sims, verdict)), (cpu, sims, verdict), key=lambda r: r[0])
        same = best[False][2] == best[True][2]
        row = {"cell": cell, "verdict": best[True][2]["effect"], "cpu_without": round(best[False][0], 2), "cpu_with": round(best[True][0], 2),
               "ratio": round(best[False][0] / best[True][0], 2), "simulations_without": best[False][1], "simulations_with": best[True][1],
               "same_verdict": same}
        print(json.dumps(row), flush=True)
        rows.append(row)
    print("\n| cell | verdict | CPU s without | CPU s with | ratio | simulate() calls without / with | same verdict |")
    print("|---|---|---:|---:|---:|---:|---|")
    for r in rows:
        print(f"| {r['cell']} | {r['verdict']} | {r['cpu_without']} | {r['cpu_with']} | {r['ratio']} | "
              f"{r['simulations_without']} / {r['simulations_with']} | {r['same_verdict']} |")
    if not all(r["same_verdict"] for r in rows):
        raise SystemExit("the memo changed a verdict")


if __name__ == "__main__":
    main()

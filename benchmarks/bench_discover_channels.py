"""`discover` on the channels a car records: the false-alarm rate on ensembles without a missing
effect, and the detection of the single-effect benchmark's effects, by channel set and run count.

Channel sets: all (psi, psi_dot, beta, y, a_y), IMU only (psi_dot, a_y), IMU + speed profile
(psi_dot, a_y while braking in the turn 70 -> 45 km/h from t = 3 s over 3 s, -2.3 m/s^2, the
speed falling by 36 %). Data: the hidden-effect reality (uqdrive.studies.hidden_effects) with the
benchmark cases' manoeuvres, noise and distribution shifts; the default config with the
discrepancy settings below (the null band bootstrapped at each file's run count).

  --part false-alarm: the six `none` cases of the benchmark x --seeds seeds x run counts
      (default 10, 20, 40): the fraction of verdicts other than `none`.
  --part detection: the IMU-visible single effects at the larger magnitude the benchmark
      (docs/discovery.md) states, one seed per cell (default 20, 40, 100 runs): the family named.

Prints one JSON line per run and Markdown tables at the end.

Usage: python benchmarks/bench_discover_channels.py --part false-alarm [--seeds 3] [--counts 10,20,40] [--sets all,imu,imu_speed]
"""

import argparse
import copy
import dataclasses
import json
import time
from collections import defaultdict
from pathlib import Path

from uqdrive.config import load_config
from uqdrive.inference.discrepancy import DiscrepancyFinder
from uqdrive.studies.hidden_effects import benchmark_cases, generate
from uqdrive.settings import Settings

SETS = {
    "all": (("psi", "psi_dot", "beta", "y", "a_y"), False),
    "imu": (("psi_dot", "a_y"), False),
    "imu_speed": (("psi_dot", "a_y"), True),
}
LABELS = {"all": "all", "imu": "IMU only", "imu_speed": "IMU + speed profile"}
BRAKING = {"start_kmh": 70.0, "end_kmh": 45.0, "t_brake": 3.0, "duration": 3.0}
#: The single-effect cases an IMU (yaw rate, lateral acceleration) can see, at the benchmark's larger magnitude.
DETECTION = ("actuator_lag_200ms", "actuator_delay_150ms", "road_bank_3deg", "wind_gust_x6", "tyre_saturation_5deg",
             "sensor_bias_psi_dot", "sensor_scale_psi_dot_125")
SETTINGS = {"model_samples": 300, "nonlinear_samples": 100, "bootstrap": 100, "max_times": 100, "top": 3}


def run(config, case, set_name, n, seed_offset=0):
    channels, braking = SETS[set_name]
    case = dataclasses.replace(case, samples=n, seed=case.seed + 1000 * seed_offset, speed=BRAKING if braking else {})
    ds = generate(config, case, channels=channels)
    t0 = time.perf_counter()
    finder = DiscrepancyFinder(Settings.from_config(config)).fit(ds)
    v = finder.verdict_
    return {"case": case.name, "set": set_name, "runs": n, "seed": case.seed, "effect": v["effect"],
            "effects": [e["effect"] for e in v["effects"]], "parameters": v["parameters"], "gap_before": v["gap_before"],
            "untestable": [u["effect"] for u in v["untestable"]], "seconds": round(time.perf_counter() - t0, 1)}


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--part", choices=("false-alarm", "detection"), required=True)
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--counts", default=None)
    parser.add_argument("--sets", default="all,imu,imu_speed")
    parser.add_argument("--cases", default=None, help="comma-separated case names (default: the part's)")
    args = parser.parse_args()
    config = load_config(Path(__file__).resolve().parents[1] / "config" / "config.yaml")  # the reproduction's candidates
    config = copy.deepcopy(config)
    config["discrepancy"].update(SETTINGS, posterior={"enabled": False})
    cases = {c.name: c for c in benchmark_cases(config)}
    sets = args.sets.split(",")
    rows = []
    if args.part == "false-alarm":
        counts = [int(c) for c in (args.counts or "10,20,40").split(",")]
        names = args.cases.split(",") if args.cases else [c for c in cases if c.startswith("none_") and cases[c].hold == "linear"]
        for n in counts:
            for s in sets:
                for name in names:
                    for seed in range(args.seeds):
                        rows.append(run(config, cases[name], s, n, seed))
                        print(json.dumps(rows[-1]), flush=True)
        table = defaultdict(list)
        for r in rows:
            table[(r["set"], r["runs"])].append(r["effect"] != "none")
        print("\n| channels | runs | files | false alarms | rate |\n|---|---:|---:|---:|---:|")
        for (s, n), alarms in sorted(table.items(), key=lambda kv: (sets.index(kv[0][0]), kv[0][1])):
            print(f"| {LABELS[s]} | {n} | {len(alarms)} | {sum(alarms)} | {sum(alarms) / len(alarms):.2f} |")
        return
    counts = [int(c) for c in (args.counts or "20,40,100").split(",")]
    names = args.cases.split(",") if args.cases else list(DETECTION)
    for n in counts:
        for s in sets:
            for name in names:
                rows.append(run(config, cases[name], s, n))
                print(json.dumps(rows[-1]), flush=True)
    print("\n| effect (magnitude) | " + " | ".join(f"{LABELS[s]}, {n}" for s in sets for n in counts) + " |")
    print("|---|" + "---|" * (len(sets) * len(counts)))
    for name in names:
        c = cases[name]
        cells = []
        for s in sets:
            for n in counts:
                r = next(r for r in rows if r["case"] == name and r["set"] == s and r["runs"] == n)
                cells.append("named" if r["effect"] == c.effect else r["effect"])
        print(f"| {c.effect} {c.magnitude:g} ({c.manoeuvre}) | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()

"""The four-wheel discovery benchmark: measured ensembles of the independent four-wheel reality
(uqdrive.vehicle.four_wheel) at 0.3-0.9 of its lateral-acceleration limit, steady and changing
inputs, each given to `uqdrive discover` as a new user would (file names carry no label, the labels
are written to a separate folder discover never reads).

    python benchmarks/bench_four_wheel.py --out DIR [--samples 500] [--cases a,b] [--no-discover]
        [--candidates a,b,...]

Writes DIR/config.yaml (the default config plus the car's cg_height and track_width), DIR/data/
case_NN.nc, DIR/labels/case_NN.json, DIR/discover/case_NN/ and DIR/summary.json; prints one line
per case (verdict, gaps, time).
"""

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

import yaml

from uqdrive.config import load_config
from uqdrive.io import write_dataset
from uqdrive.studies.four_wheel import amplitude_for, case_label, four_wheel_cases, generate, steady_limit
from uqdrive.vehicle.four_wheel import FourWheelCar

CG_HEIGHT, TRACK_WIDTH = 0.55, 1.6  # m, a 1.8 t saloon's (the four-wheel car's defaults)
CANDIDATES = ("tyre_saturation,actuator_lag,actuator_delay,road_bank,wind_gust,lateral_kinematics,sensor_bias,sensor_scale,"
              "longitudinal_load_transfer,lateral_load_transfer,compliance_steer,tyre_relaxation")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", required=True, type=Path)
    ap.add_argument("--samples", type=int, default=500)
    ap.add_argument("--cases", default=None, help="comma-separated case names (default: all)")
    ap.add_argument("--candidates", default=CANDIDATES)
    ap.add_argument("--no-discover", action="store_true", help="only generate the data")
    args = ap.parse_args(argv)
    out = args.out
    for sub in ("data", "labels", "discover"):
        (out / sub).mkdir(parents=True, exist_ok=True)
    config = load_config(None)
    config["vehicle"].update(cg_height=CG_HEIGHT, track_width=TRACK_WIDTH)
    (out / "config.yaml").write_text(yaml.safe_dump(config, sort_keys=False))
    car = FourWheelCar.from_config(config)
    limit = steady_limit(config, car)
    cases = four_wheel_cases(config, samples=args.samples)
    if args.cases:
        keep = set(args.cases.split(","))
        cases = [c for c in cases if c.name in keep]
    summary = []
    for i, case in enumerate(four_wheel_cases(config, samples=args.samples)):
        if case not in cases:
            continue
        tag = f"case_{i + 1:02d}"
        data = out / "data" / f"{tag}.nc"
        if not data.exists():
            amplitude = amplitude_for(config, car, case, limit)
            write_dataset(generate(config, case, amplitude, car), data)
            (out / "labels" / f"{tag}.json").write_text(json.dumps(case_label(case, amplitude, limit, car), indent=1))
        row = {"case": tag, "name": case.name}
        if not args.no_discover:
            target = out / "discover" / tag
            t0 = time.perf_counter()
            run = subprocess.run([sys.executable, "-m", "uqdrive.cli.main", "discover", str(data), "--config", str(out / "config.yaml"),
                                  "--candidates", args.candidates, "--out", str(target), "--no-posterior", "--force"],
                                 capture_output=True, text=True)
            row["seconds"] = round(time.perf_counter() - t0, 1)
            if run.returncode:
                row["error"] = run.stderr.strip().splitlines()[-1] if run.stderr.strip() else f"exit {run.returncode}"
            else:
                v = json.loads((target / "verdict.json").read_text())
                row.update({k: v.get(k) for k in ("effect", "effects", "gap_before", "gap_after", "parameters", "ambiguous_with", "warnings")})
        summary.append(row)
        print(json.dumps(row, default=str), flush=True)
    (out / "summary.json").write_text(json.dumps(summary, indent=1, default=str))


if __name__ == "__main__":
    main()

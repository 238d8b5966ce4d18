"""The real-tyres discovery benchmark: measured ensembles of the independent Pacejka single-track
reality (uqdrive.vehicle.realities: load-dependent tyres, wheel spin, combined slip, a speed-holding
drive) in a step and a slalom at 0.3, 0.6 and 0.9 of its limit, a car whose tyres have their own
shape and a multi-body-like car (roll camber, relaxing tyres), each given to `uqdrive discover`
with every registered candidate, as a new user would (labels in a folder discover never reads).

    python benchmarks/bench_real_tyres.py --out DIR [--samples 200] [--cases a,b] [--json FILE]

A run merges its cases' rows into the rows of --json (when it exists) and of DIR/summary.json (a
case run again replaces its row) and writes them all to both: one case can be added to the record.
    python benchmarks/bench_real_tyres.py --out DIR --table      # the results table of docs/real_tyres.md

Writes DIR/config.yaml (the default config plus cg_height and track_width: the vehicle file a user
would enter for this car), DIR/data/case_NN.nc, DIR/labels/case_NN.json, DIR/discover/case_NN/,
and the summary (one row per case: verdict, named effects with their intervals, gaps, chi2 steps,
CPU time) to DIR/summary.json and ``--json``; prints one line per case and the table.
"""

import argparse
import json
import subprocess
import sys
from pathlib import Path

import yaml

import judgement

from uqdrive.config import load_config
from uqdrive.io import write_dataset
from uqdrive.studies.real_tyres import CARS, amplitude_for, case_label, generate, real_tyre_cases, steady_limit

CG_HEIGHT, TRACK_WIDTH = 0.55, 1.6  # m: the car's; the track is what a user enters for a real car, the reality has none

#: Effects the reality has (a named effect outside it is a false one), and those it has not; the
#: rolling car's front roll camber is a steer by the roll mode (roll_steer's physics), its rear's no candidate's.
PRESENT = ("tyre_saturation", "tyre_shape", "lateral_kinematics", "longitudinal_load_transfer", "load_sensitive_tyre", "combined_slip",
           "unrecognised")
ABSENT = ("lateral_load_transfer", "road_bank", "wind_gust", "sensor_bias", "sensor_scale", "actuator_lag", "actuator_delay",
          "compliance_steer", "roll_steer", "tyre_relaxation")
PRESENT_BY_CAR = {"sedan": PRESENT, "reshaped": PRESENT, "rolling": PRESENT + ("roll_steer", "tyre_relaxation"),
                  "roll_steering": PRESENT + ("roll_steer", "tyre_relaxation")}

#: What discover should name on each case (docs/real_tyres.md, stated before the run), order free.
EXPECTED = {
    "rt_step_030": "lateral_kinematics (k = 1); load_sensitive_tyre possible; nothing else",
    "rt_step_060": "lateral_kinematics, tyre_saturation; load_sensitive_tyre or an `unrecognised` rest",
    "rt_step_090": "tyre_saturation, lateral_kinematics, load_sensitive_tyre; `unrecognised` rest possible",
    "rt_slalom_030": "lateral_kinematics; load_sensitive_tyre possible",
    "rt_slalom_060": "lateral_kinematics, tyre_saturation; load_sensitive_tyre or an `unrecognised` rest",
    "rt_slalom_090": "tyre_saturation, lateral_kinematics, load_sensitive_tyre or combined_slip; `unrecognised` rest possible "
                     "(the slalom's peaks reach the tyres' saturation, so the Magic Formula carries most of the gap; the course angle "
                     "is the reality's at every level; the drive force that holds the speed against the tyres' cornering drag takes "
                     "the rear's lateral capacity and moves load forwards; the wheels' own slip dynamics are no candidate's)",
    "rt_shape_step_090": "tyre_shape with b 1.45, C 1.3, E -0.3 in its intervals, lateral_kinematics; nothing else",
    "rt_roll_slalom_060": "roll_steer (the front camber: K about 0.7 deg/g, f 1.4 Hz), tyre_relaxation (sigma 0.6 m), lateral_kinematics, "
                          "tyre_saturation or tyre_shape; the rear camber an `unrecognised` rest",
    "rt_rollsteer_slalom_060": "roll_steer, closing at least half of the chi2 excess alone (the front's roll steer and camber: 1.8 deg/g, "
                               "less the rear camber's 0.6 at steady state, so K 1.2 to 1.8 deg/g, f about 1.4 Hz); lateral_kinematics, "
                               "tyre_saturation or tyre_shape, tyre_relaxation possible; the rear camber's side slip an `unrecognised` rest",
}


def judge(row: dict) -> str:
    """The shared judgement (judgement.judge) against the effects of the row's car."""
    return judgement.judge(row, PRESENT_BY_CAR[row.get("car", "sedan")])


def table(rows) -> str:
    """Markdown results table of the summary rows."""
    lines = ["| case | expected (stated before) | named: parameters [95 %] | gap before -> after | judged | CPU |", "|---|---|---|---|---|---|"]
    for r in rows:
        if "error" in r:
            lines.append(f"| {r['name']} | {EXPECTED.get(r['name'], '')} | error: {r['error']} | | | |")
            continue
        named = "; ".join(judgement.effect_cell(e) for e in r.get("effects") or []) or "`none`"
        lines.append(f"| {r['name']} | {EXPECTED.get(r['name'], '')} | {named} | {r['gap_before']:.3g} -> {r['gap_after']:.3g} | "
                     f"{judge(r)} | {r['seconds']:.0f} s |")
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", required=True, type=Path)
    ap.add_argument("--samples", type=int, default=200)
    ap.add_argument("--cases", default=None, help="comma-separated case names (default: all six)")
    ap.add_argument("--candidates", default="all")
    ap.add_argument("--json", type=Path, default=None, help="also write the summary here (the docs table's source)")
    ap.add_argument("--table", action="store_true", help="print the table of DIR/summary.json and exit")
    args = ap.parse_args(argv)
    out = args.out
    if args.table:
        print(table(json.loads((out / "summary.json").read_text())))
        return
    for sub in ("data", "labels", "discover"):
        (out / sub).mkdir(parents=True, exist_ok=True)
    config = load_config(None)
    config["vehicle"].update(cg_height=CG_HEIGHT, track_width=TRACK_WIDTH)
    (out / "config.yaml").write_text(yaml.safe_dump(config, sort_keys=False))
    limits = {}
    keep = set(args.cases.split(",")) if args.cases else None
    old = judgement.merged_rows(args.json, out / "summary.json")  # the record's rows, then this folder's (newer) ones
    for i, case in enumerate(real_tyre_cases(config, samples=args.samples)):
        if keep and case.name not in keep:
            continue
        tag = f"case_{i + 1:02d}"
        data = out / "data" / f"{tag}.nc"
        car = CARS[case.car]
        if not data.exists():
            limit = limits[case.car] = limits.get(case.car) or steady_limit(config, car)
            amplitude = amplitude_for(config, car, case, limit)
            write_dataset(generate(config, case, amplitude, car), data)
            (out / "labels" / f"{tag}.json").write_text(json.dumps(case_label(case, amplitude, limit, car), indent=1))
        row = {"case": tag, "name": case.name, "car": case.car, "level": case.level, "runs": case.samples,
               "amplitude_deg": json.loads((out / "labels" / f"{tag}.json").read_text())["amplitude_deg"]}
        target = out / "discover" / tag
        cpu0 = judgement.children_cpu()
        run = subprocess.run([sys.executable, "-m", "uqdrive.cli.main", "discover", str(data), "--config", str(out / "config.yaml"),
                              "--candidates", args.candidates, "--out", str(target), "--no-posterior", "--force"],
                             capture_output=True, text=True)
        row["seconds"] = round(judgement.children_cpu() - cpu0, 1)
        (out / "labels" / f"{tag}.discover.log").write_text(run.stderr)  # the progress lines: which candidates each step fitted
        if run.returncode:
            row["error"] = run.stderr.strip().splitlines()[-1] if run.stderr.strip() else f"exit {run.returncode}"
        else:
            row.update(judgement.verdict_row(json.loads((target / "verdict.json").read_text())))
            row["judged"] = judge(row)
        old[case.name] = row
        print(json.dumps(row, default=str), flush=True)
        rows = [old[c.name] for c in real_tyre_cases(config, samples=args.samples) if c.name in old]
        text = json.dumps(rows, indent=1, default=str)
        (out / "summary.json").write_text(text)
        if args.json:
            args.json.write_text(text + "\n")
    print(table([old[c.name] for c in real_tyre_cases(config, samples=args.samples) if c.name in old]))


if __name__ == "__main__":
    main()

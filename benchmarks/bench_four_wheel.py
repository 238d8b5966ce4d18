"""The four-wheel discovery benchmark: measured ensembles of the independent four-wheel reality
(uqdrive.vehicle.four_wheel) at 0.3-0.9 of its lateral-acceleration limit, steady and changing
inputs, each given to `uqdrive discover` as a new user would (file names carry no label, the labels
are written to a separate folder discover never reads).

    python benchmarks/bench_four_wheel.py --out DIR [--samples 500] [--cases a,b] [--no-discover]
        [--candidates a,b,...]
    python benchmarks/bench_four_wheel.py --out DIR --table     # the results table of docs/four_wheel.md

Writes DIR/config.yaml (the default config plus the car's cg_height and track_width), DIR/data/
case_NN.nc, DIR/labels/case_NN.json, DIR/discover/case_NN/ and DIR/summary.json; prints one line
per case (verdict, gaps, time). ``--table`` reads DIR/discover/*/verdict.json and prints the
Markdown results table (named effects with their 95 % intervals, gap before and after against
the null band, the expectation stated before the run).
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
from uqdrive.settings import Settings

CG_HEIGHT, TRACK_WIDTH = 0.55, 1.6  # m, a 1.8 t saloon's (the four-wheel car's defaults)
CANDIDATES = ("tyre_saturation,actuator_lag,actuator_delay,road_bank,wind_gust,lateral_kinematics,sensor_bias,sensor_scale,"
              "longitudinal_load_transfer,lateral_load_transfer,compliance_steer,tyre_relaxation,roll_steer")


#: Reduced discover settings (``--quick``): the combined benchmark's at 300 runs in docs/discovery.md.
QUICK = {"model_samples": 400, "nonlinear_samples": 150, "bootstrap": 100, "max_times": 80}

#: What discover should name on each case (docs/four_wheel.md, stated before the run), order free.
EXPECTED = {
    "fw_step_030": "lateral_kinematics, roll_steer (compliance_steer without the roll_steer candidate)",
    "fw_step_060": "lateral_kinematics, tyre_saturation, compliance_steer, lateral_load_transfer",
    "fw_step_090": "lateral_kinematics, tyre_saturation, lateral_load_transfer, compliance_steer",
    "fw_slalom_050": "roll_steer (compliance_steer without it), lateral_kinematics (tyre_saturation possible)",
    "fw_slalom_090": "tyre_saturation, lateral_load_transfer, compliance_steer (unrecognised rest possible)",
    "fw_chirp_060": "compliance_steer, tyre_relaxation or actuator_lag, lateral_load_transfer or tyre_saturation",
}


def _effect_cell(e) -> str:
    params = ", ".join(f"{k} {v[0]:.3g} [{v[1]:.3g}, {v[2]:.3g}]" for k, v in e.get("parameters", {}).items() if isinstance(v, list))
    amb = f" (~{', '.join(e['ambiguous_with'])})" if e.get("ambiguous_with") else ""
    return f"`{e['effect']}`{amb}" + (f": {params}" if params else "") + (f" -> {e['gap_after']:.3g}" if "gap_after" in e else "")


def results_table(out: Path) -> str:
    """Markdown table of the verdicts in ``out``/discover/case_NN/verdict.json (labels from ``out``/labels)."""
    lines = ["| case | level | expected (stated before) | named, in order: parameters [95 %] -> gap after | gap before -> after | "
             "within the null band | baseline mu, l_f means before -> after | model realisations, replicates | time |",
             "|---|---|---|---|---|---|---|---|---|"]
    for target in sorted((out / "discover").glob("case_*")):
        vfile, lfile = target / "verdict.json", out / "labels" / f"{target.name}.json"
        if not (vfile.exists() and lfile.exists()):
            continue
        v, label = json.loads(vfile.read_text()), json.loads(lfile.read_text())
        ev = v["evidence"]
        effects = v.get("effects", [{"effect": v["effect"], "parameters": v.get("parameters", {})}] if v["effect"] != "none" else [])
        named = "; ".join(_effect_cell(e) for e in effects) or "`none`"
        steps = ev.get("steps") or []
        if steps and steps[-1]["explains"]:
            inside = "yes"
        elif any(e["effect"] == "unrecognised" for e in effects):
            inside = "no (`unrecognised` rest)"
        else:  # no excess misfit, but a statistic of one time and channel above the band's threshold
            inside = "its misfit (gap 0), not its largest statistic" if v["gap_after"] == 0 else "no"
        d = v["distributions"]
        dist = f"{d['before']['mu']['mean']:.2f}, {d['before']['l_f']['mean']:.2f} -> {d['after']['mu']['mean']:.2f}, {d['after']['l_f']['mean']:.2f}"
        lines.append(f"| {target.name} {label['name']} | {label['level']} | {EXPECTED.get(label['name'], '')} | {named} | "
                     f"{v['gap_before']:.3g} -> {v['gap_after']:.3g} | {inside} | {dist} | {ev.get('model_samples')}, {ev.get('bootstrap_replicates')} | "
                     f"{ev.get('seconds', float('nan')):.0f} s |")
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", required=True, type=Path)
    ap.add_argument("--samples", type=int, default=500)
    ap.add_argument("--cases", default=None, help="comma-separated case names (default: all)")
    ap.add_argument("--candidates", default=CANDIDATES)
    ap.add_argument("--no-discover", action="store_true", help="only generate the data")
    ap.add_argument("--quick", action="store_true", help=f"discover with the reduced settings {QUICK} (about 4x faster)")
    ap.add_argument("--table", action="store_true", help="print the results table of the verdicts in --out and exit")
    ap.add_argument("--channels", default=None,
                    help="comma-separated measured channels written to the data (default: all the generator records, "
                         "psi, psi_dot, beta, y, a_y), e.g. --channels psi,psi_dot,beta,y for the four states only")
    args = ap.parse_args(argv)
    out = args.out
    if args.table:
        print(results_table(out))
        return
    for sub in ("data", "labels", "discover"):
        (out / sub).mkdir(parents=True, exist_ok=True)
    config = load_config(None)
    config["vehicle"].update(cg_height=CG_HEIGHT, track_width=TRACK_WIDTH)
    if args.quick:
        config["discrepancy"].update(QUICK)
    (out / "config.yaml").write_text(yaml.safe_dump(config, sort_keys=False))
    car = FourWheelCar.from_vehicle(Settings.from_config(config).vehicle)
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
            ds = generate(config, case, amplitude, car)
            if args.channels:
                keep_channels = set(args.channels.split(","))
                ds = ds.drop_vars([v for v in ds.data_vars if v != "delta" and v not in keep_channels])
            write_dataset(ds, data)
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

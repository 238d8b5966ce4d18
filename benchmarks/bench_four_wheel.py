"""The four-wheel discovery benchmark: measured ensembles of the independent four-wheel reality
(uqdrive.vehicle.four_wheel) at 0.3-0.9 of its lateral-acceleration limit, steady and changing
inputs, each given to `uqdrive discover` as a new user would (file names carry no label, the labels
are written to a separate folder discover never reads), each verdict judged against the reality.

    python benchmarks/bench_four_wheel.py --out DIR [--samples 500] [--cases a,b] [--json FILE]
        [--no-discover] [--candidates a,b,...] [--quick] [--channels a,b] [--device cpu|gpu|auto] [--jobs N|auto]
    python benchmarks/bench_four_wheel.py --out DIR --table     # the results table of DIR/summary.json
    python benchmarks/bench_four_wheel.py --out DIR --rejudge [--json FILE]   # rows again from DIR's verdicts

Writes DIR/config.yaml (the default config plus the car's cg_height and track_width), DIR/data/
case_NN.nc, DIR/labels/case_NN.json (and the discover log beside it), DIR/discover/case_NN/ and
the summary (one row per case: the named effects with their intervals and the car's values, the
gaps, the first step's best candidate and its share of the chi2 excess, the judgement, CPU time)
to DIR/summary.json and ``--json``. A run merges its cases' rows into the rows of --json (when it
exists) and of DIR/summary.json (a case run again replaces its row): one case can be added to the
record. ``--rejudge`` rebuilds the rows of DIR/summary.json from DIR's verdicts and labels, keeping
their CPU times (a changed judgement without a rerun).
"""

import argparse
import json
import math
import subprocess
import sys
import time
from pathlib import Path

import yaml

import judgement
from uqdrive.config import load_config
from uqdrive.io import write_dataset
from uqdrive.studies.four_wheel import amplitude_for, case_label, four_wheel_cases, generate, steady_limit
from uqdrive.vehicle.four_wheel import FourWheelCar
from uqdrive.settings import Settings

CG_HEIGHT, TRACK_WIDTH = 0.55, 1.6  # m, a 1.8 t saloon's (the four-wheel car's defaults)
CANDIDATES = "all"  # every registered candidate

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

#: The effects the four-wheel reality has (a verdict may name them), each with the physics of
#: uqdrive.vehicle.four_wheel that carries it.
PRESENT = {
    "lateral_kinematics": "the body moves along its course angle, Y' = v_x sin psi + v_y cos psi",
    "tyre_saturation": "every wheel's Magic Formula saturates at its peak mu F_z (1 + p_Dz dfz)",
    "tyre_shape": "an axle's force is the sum of two wheels at different loads, each with its load's K_y: "
                  "not the vehicle file's single curve",
    "load_sensitive_tyre": "the cornering stiffness K_y(F_z) (q_Ky) and the peak (p_Dz) depend on the wheel's load",
    "lateral_load_transfer": "a track and roll springs front and rear move load across each axle",
    "longitudinal_load_transfer": "a centre of gravity above the ground and a pitch mode move load between the axles",
    "combined_slip": "the drive force that holds the speed takes the rear wheels' lateral capacity (friction ellipse)",
    "roll_steer": "the front wheels steer by -e_f phi through the roll mode",
    "compliance_steer": "the roll steer's steady part: a front steer in proportion to the lateral force, the roll mode taken as instant",
    "tyre_relaxation": "the slip angles lag their steady values over the relaxation length",
    "unrecognised": "what no candidate carries: each wheel's own saturation, the roll and pitch modes' transients",
}
#: The registered effects it has not, each with the reason.
ABSENT = {
    "actuator_lag": "the steering acts at the wheels as commanded",
    "actuator_delay": "the steering acts at the wheels as commanded",
    "road_bank": "the road is flat",
    "wind_gust": "its side wind is the config's (the model's own mean and gusts)",
    "sensor_bias": "its measurement noise is white with zero mean",
    "sensor_scale": "its channels are measured without gain error",
}


def car_values(car: dict, m_load: float) -> dict[str, dict[str, float]]:
    """The car's own value of each candidate parameter that has one in the four-wheel reality
    (``car`` its constants, ``m_load`` the mean load, kg), for reading a named effect's interval.

    The roll steer's steady gain is e_f phi per g of lateral force over the base mass, the steady
    roll phi = h m_base g / (K_phi - m g h) (the roll equation without its rates, m = m_base +
    m_load); its frequency and damping are the roll mode's, sqrt((K_phi - m g h) / (I_x + m h^2))
    / (2 pi) and C_phi / (2 sqrt((K_phi - m g h) (I_x + m h^2))). The load-sensitive tyre's q is
    the slope of K_y(F_z) / (F_z K_y0 / F_z0) at the static load, d/dx sin(2 atan(x / q_Ky)) /
    sin(2 atan(1 / q_Ky)) - 1 at x = 1.
    """
    m, h, g = car["m_base"] + m_load, car["cg_height"], car["g"]
    k_phi = car["roll_stiffness_front"] + car["roll_stiffness_rear"]
    stiff, inertia = k_phi - m * g * h, car["roll_inertia"] + m * h ** 2
    steer = math.degrees(car["roll_steer_front"] * h * car["m_base"] * g / stiff)  # deg/g
    qk = car["q_Ky"]
    q = math.cos(2 * math.atan(1 / qk)) * 2 / qk / (1 + 1 / qk ** 2) / math.sin(2 * math.atan(1 / qk)) - 1
    return {
        "lateral_kinematics": {"k": 1.0},
        "tyre_saturation": {"E": car["E"]},
        "tyre_shape": {"b": 1.0, "C": car["C"], "E": car["E"]},
        "load_sensitive_tyre": {"q": q, "p_Dz": car["p_Dz"]},
        "lateral_load_transfer": {"chi_f": car["roll_stiffness_front"] / k_phi, "p_Dz": car["p_Dz"]},
        "longitudinal_load_transfer": {"h": h},
        "combined_slip": {"kappa": 1.0, "chi_d": car["drive_front_share"]},
        "compliance_steer": {"K": steer},
        "roll_steer": {"K": steer, "f": math.sqrt(stiff / inertia) / (2 * math.pi),
                       "zeta": (car["roll_damping_front"] + car["roll_damping_rear"]) / (2 * math.sqrt(stiff * inertia))},
        "tyre_relaxation": {"sigma": car["relaxation_length"]},
    }


def judge(row: dict) -> str:
    """The shared judgement (judgement.judge) against the four-wheel reality's effects."""
    return judgement.judge(row, PRESENT)


def _named_cell(e: dict, car: dict) -> str:
    cell = judgement.effect_cell(e)
    own = car.get(e["effect"], {})
    known = [f"{k} {own[k]:.3g}" for k in e.get("parameters", {}) if k in own]
    return cell + (f" (car: {', '.join(known)})" if known else "")


def table(rows) -> str:
    """Markdown results table of the summary rows: the named effects with their 95 % intervals and
    the car's values, the gaps, the first step's best candidate, the judgement and the cost."""
    lines = ["| case | level | expected (stated before) | named: parameters [95 %] (the car's) | gap before -> after | "
             "best candidate: share of the chi2 excess | judged | model realisations | CPU |", "|---|---:|---|---|---|---|---|---:|---:|"]
    for r in rows:
        if "error" in r:
            lines.append(f"| {r['name']} | {r['level']:g} | {EXPECTED.get(r['name'], '')} | error: {r['error']} | | | | | |")
            continue
        named = "; ".join(_named_cell(e, r.get("car_values", {})) for e in r.get("effects") or []) or "`none`"
        best = r.get("best") or {}
        share = f"`{best['effect']}` {best['share_closed']:.2f}" if best.get("share_closed") is not None else "-"
        lines.append(f"| {r['name']} | {r['level']:g} | {EXPECTED.get(r['name'], '')} | {named} | {r['gap_before']:.3g} -> {r['gap_after']:.3g} | "
                     f"{share} | {judge(r)} | {r.get('model_samples', '-')} | {r['cpu_seconds']:.0f} s |")
    return "\n".join(lines)


def case_row(out: Path, tag: str, name: str, m_load: float) -> dict:
    """The summary row of case ``tag`` from ``out``'s label and verdict (no CPU time)."""
    label = json.loads((out / "labels" / f"{tag}.json").read_text())
    row = {"case": tag, "name": name, "level": label["level"], "runs": label["samples"], "amplitude_deg": label["amplitude_deg"],
           "expected": EXPECTED.get(name, "")}
    verdict_file = out / "discover" / tag / "verdict.json"
    if not verdict_file.exists():
        return row
    v = json.loads(verdict_file.read_text())
    row.update(judgement.verdict_row(v))
    values = car_values(label["car"], m_load)
    row["car_values"] = {e["effect"]: values[e["effect"]] for e in row["effects"] or [] if e["effect"] in values}
    row["judged"] = judge(row)
    row["model_samples"] = v["evidence"].get("model_samples")
    row["bootstrap_replicates"] = v["evidence"].get("bootstrap_replicates")
    return row


def _write(rows: dict, order, out: Path, record: Path | None) -> list[dict]:
    """The ``rows`` in case ``order`` to ``out``/summary.json and ``record``."""
    rows = [rows[name] for name in order if name in rows]
    text = json.dumps(rows, indent=1, default=str)
    (out / "summary.json").write_text(text)
    if record is not None:
        record.write_text(text + "\n")
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", required=True, type=Path)
    ap.add_argument("--samples", type=int, default=500)
    ap.add_argument("--cases", default=None, help="comma-separated case names (default: all)")
    ap.add_argument("--candidates", default=CANDIDATES)
    ap.add_argument("--json", type=Path, default=None, help="also write the summary here (the docs table's source)")
    ap.add_argument("--no-discover", action="store_true", help="only generate the data")
    ap.add_argument("--quick", action="store_true", help=f"discover with the reduced settings {QUICK} (about 4x faster)")
    ap.add_argument("--table", action="store_true", help="print the results table of DIR/summary.json and exit")
    ap.add_argument("--rejudge", action="store_true", help="rebuild the rows of DIR/summary.json from DIR's verdicts, keeping their CPU times")
    ap.add_argument("--device", default="cpu", choices=("auto", "cpu", "gpu"), help="discover's --device (default cpu)")
    ap.add_argument("--jobs", default="1", help="discover's --jobs (default 1)")
    ap.add_argument("--channels", default=None,
                    help="comma-separated measured channels written to the data (default: all the generator records, "
                         "psi, psi_dot, beta, y, a_y), e.g. --channels psi,psi_dot,beta,y for the four states only")
    args = ap.parse_args(argv)
    out = args.out
    if args.table:
        print(table(json.loads((out / "summary.json").read_text())))
        return
    config = load_config(None)
    config["vehicle"].update(cg_height=CG_HEIGHT, track_width=TRACK_WIDTH)
    if args.quick:
        config["discrepancy"].update(QUICK)
    m_load = float(config["uncertainty"]["m_load"]["mean"])
    order = [c.name for c in four_wheel_cases(config, samples=args.samples)]
    rows = judgement.merged_rows(args.json, out / "summary.json")  # the record's rows, then this folder's (newer) ones
    if args.rejudge:
        for name, old in judgement.merged_rows(out / "summary.json").items():
            rows[name] = {**case_row(out, old["case"], name, m_load), **{k: old[k] for k in ("cpu_seconds", "seconds") if k in old}}
        print(table(_write(rows, order, out, args.json)))
        return
    for sub in ("data", "labels", "discover"):
        (out / sub).mkdir(parents=True, exist_ok=True)
    (out / "config.yaml").write_text(yaml.safe_dump(config, sort_keys=False))
    car = FourWheelCar.from_vehicle(Settings.from_config(config).vehicle)
    limit = steady_limit(config, car)
    keep = set(args.cases.split(",")) if args.cases else None
    for i, case in enumerate(four_wheel_cases(config, samples=args.samples)):
        if keep and case.name not in keep:
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
        if args.no_discover:
            continue
        target = out / "discover" / tag
        cpu0, wall0 = judgement.children_cpu(), time.perf_counter()
        run = subprocess.run([sys.executable, "-m", "uqdrive.cli.main", "discover", str(data), "--config", str(out / "config.yaml"),
                              "--candidates", args.candidates, "--out", str(target), "--no-posterior", "--force", "--device", args.device,
                              "--jobs", args.jobs], capture_output=True, text=True)
        cpu, wall = round(judgement.children_cpu() - cpu0, 1), round(time.perf_counter() - wall0, 1)
        (out / "labels" / f"{tag}.discover.log").write_text(run.stderr)  # the progress lines: which candidates each step fitted
        if run.returncode:
            row = {"case": tag, "name": case.name, "level": case.level,
                   "error": run.stderr.strip().splitlines()[-1] if run.stderr.strip() else f"exit {run.returncode}"}
        else:
            row = case_row(out, tag, case.name, m_load)
        rows[case.name] = {**row, "cpu_seconds": cpu, "wall_seconds": wall, "device": args.device, "jobs": args.jobs}
        print(json.dumps(rows[case.name], default=str), flush=True)
        _write(rows, order, out, args.json)
    if not args.no_discover:
        print(table([rows[name] for name in order if name in rows]))


if __name__ == "__main__":
    main()

"""`discover` runs on 1000 samples against the budget of 3 minutes on 2 cores: the thesis' case
(NLST data against the LST) and a case with three hidden effects at once (course angle, road
bank, actuator lag; `--case combined_course_bank_lag`); prints the time of each stage and the
ratio to budget, and the emcee posterior's share when the config samples it (discrepancy.posterior).

`--case braking_in_turn_lag`: braking in a turn (ISO 7975, uqdrive.studies.manoeuvres.braking_in_turn:
a 2 deg step steer at 1 s, the speed falling 80 -> 50 km/h from 3 s over 3 s) with a 0.15 s
steering lag, recorded as a car's IMU and wheel speeds record it (psi_dot, a_y and v over time,
no beta, no y); the model is the linear single-track model along the measured speed (RK4).
`--samples` sets the run count (default 1000).

`--chassis`: the config gains the car's cg_height 0.55 m and track_width 1.6 m and the candidates
longitudinal_load_transfer, lateral_load_transfer, compliance_steer, tyre_relaxation and roll_steer, which
puts the benchmark's chassis cases in reach of `--case` (e.g. `--chassis --case
compliance_steer_05`). `--quick`: the reduced discover settings of the combined benchmark at 300
runs (docs/discovery.md: 400 model and 150 non-linear realisations, 100 replicates, 80 compared
times, no posterior). Each named effect is printed with its 95 % intervals and the gap after it;
`--keep DIR` keeps discover's output folder (verdict.json with the evidence, figures)."""

import json
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import yaml

from uqdrive.config import load_config
from uqdrive.io import write_dataset
from uqdrive.studies.hidden_effects import HiddenEffectCase, benchmark_cases, generate
from uqdrive.vehicle.channels import CHANNELS

BUDGET = 180.0
CHASSIS_CAR = {"cg_height": 0.55, "track_width": 1.6}  # m, a 1.8 t saloon's (as benchmarks/bench_four_wheel.py)
CHASSIS = ("longitudinal_load_transfer", "lateral_load_transfer", "compliance_steer", "tyre_relaxation", "roll_steer")
QUICK = {"model_samples": 400, "nonlinear_samples": 150, "bootstrap": 100, "max_times": 80}
#: Cases with a changing speed: (case, measured channels).
SPEED_CASES = {
    "braking_in_turn_lag": (lambda n, seed: HiddenEffectCase("braking_in_turn_lag", "actuator_lag", 0.15, "step",
                                                             {"amplitude_deg": 2.0, "t_start": 1.0, "ramp": 0.4}, n, seed,
                                                             speed={"start_kmh": 80.0, "end_kmh": 50.0, "t_brake": 3.0, "duration": 3.0}),
                            ("psi_dot", "a_y")),
}


def main(argv=None):
    import argparse

    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--case", default="thesis_nlst", help="benchmark case (uqdrive.studies.hidden_effects.benchmark_cases, or braking_in_turn_lag)")
    parser.add_argument("--samples", type=int, default=1000)
    parser.add_argument("--chassis", action="store_true", help="add the car's cg_height, track_width and the chassis candidates")
    parser.add_argument("--quick", action="store_true", help="reduced discover settings (docs/discovery.md), no posterior")
    parser.add_argument("--keep", type=Path, help="copy discover's output folder (verdict.json, figures) to this new folder")
    args = parser.parse_args(argv)
    config = load_config(Path(__file__).resolve().parents[1] / "config" / "config.yaml")  # the reproduction's candidates
    if args.chassis:
        config["vehicle"].update(CHASSIS_CAR)
        config["discrepancy"]["candidates"] = list(config["discrepancy"]["candidates"]) + list(CHASSIS)
    if args.quick:
        config["discrepancy"].update(QUICK)
        config["discrepancy"]["posterior"]["enabled"] = False
    if args.case in SPEED_CASES:
        make, channels = SPEED_CASES[args.case]
        case = make(args.samples, int(config["seed"]) + 900)
    else:
        case, channels = {c.name: c for c in benchmark_cases(config, samples=args.samples)}[args.case], CHANNELS[:4]
    with tempfile.TemporaryDirectory() as tmp:
        measured, config_file = Path(tmp) / "measured.nc", Path(tmp) / "config.yaml"
        write_dataset(generate(config, case, channels=channels), measured)
        config_file.write_text(yaml.safe_dump(config, sort_keys=False))
        t0, c0 = time.perf_counter(), resource.getrusage(resource.RUSAGE_CHILDREN)
        subprocess.run([sys.executable, "-m", "uqdrive.cli.main", "discover", str(measured), "--config", str(config_file), "--out", str(Path(tmp) / "out")],
                       check=True)
        wall, c1 = time.perf_counter() - t0, resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu = (c1.ru_utime + c1.ru_stime) - (c0.ru_utime + c0.ru_stime)  # the discover process's CPU time: less sensitive to the machine's load than wall time
        verdict = json.loads((Path(tmp) / "out" / "verdict.json").read_text())
        if args.keep:
            shutil.copytree(Path(tmp) / "out", args.keep)
    stages = verdict["evidence"]["stage_seconds"]
    post = verdict.get("posterior")
    named = [e["effect"] for e in verdict["effects"]] or [verdict["effect"]]
    print(f"discover, {args.samples} samples, {args.case} ({', '.join(channels)}): {wall:.1f} s wall, {cpu:.1f} s CPU (budget {BUDGET:.0f} s, ratio {wall / BUDGET:.2f}); "
          f"effects {named}, gap {verdict['gap_before']} -> {verdict['gap_after']}, "
          f"parameters {[e['parameters'] for e in verdict['effects']]}, untestable {[u['effect'] for u in verdict.get('untestable', [])]}, stages {stages}")
    if post:  # the optional emcee posterior (config discrepancy.posterior) is part of the wall time above
        print(f"  of which the emcee posterior: {stages.get('posterior', float('nan')):.1f} s (without it {wall - stages.get('posterior', 0.0):.1f} s); "
              f"mu mean {post['mu_mean'][0]:.4f} [{post['mu_mean'][1]:.4f}, {post['mu_mean'][2]:.4f}], "
              f"R-hat max {max(post['r_hat'].values()):.3f}, tau max {max(post['tau'].values()):.0f}, "
              f"{post['model_evaluations']} model evaluations, surrogate validated {post['surrogate']['passed']}")
    for e in verdict["effects"]:
        params = ", ".join(f"{k} {v[0]:.4g} [{v[1]:.4g}, {v[2]:.4g}]" for k, v in e.get("parameters", {}).items() if isinstance(v, list))
        print(f"  {e['effect']}{' (~' + ', '.join(e['ambiguous_with']) + ')' if e.get('ambiguous_with') else ''}: {params} -> gap {e.get('gap_after')}")
    print(f"  gap {verdict['gap_before']} -> {verdict['gap_after']}")


if __name__ == "__main__":
    main()

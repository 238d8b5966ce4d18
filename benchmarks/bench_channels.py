"""Identification error and standard error of mu against the run count (10, 20, 40, 100, 1000) and
the channel set: all channels (psi, psi_dot, beta, y, a_y), an IMU only (psi_dot, a_y), and an IMU
while braking (psi_dot, a_y with the speed falling 80 -> 50 km/h, the braking_in_turn speed).

Data: LST ensembles of the default car (slalom (5.5), 4 s on a 0.05 s grid, no gusts) with 1 %
noise (5.6), --replicates seeds per cell (default 2); the fit starts at mu N(0.8, 0.3), away from the truth
N(1.0, 0.2) of the config. Error = |estimate - config truth| averaged over the replicates (the
sampling error of n runs, 0.2 / sqrt(n) for the mean, is part of it); SE = the mean reported
standard error. Prints a Markdown table (docs/data_schema.md holds a copy).

Usage: python benchmarks/bench_channels.py [--replicates R] [--counts 10,20,...]
"""

import argparse
import copy
import json
import tempfile
import time
from pathlib import Path

import numpy as np

from uqdrive.cli.identify import identify_file
from uqdrive.config import load_config
from uqdrive.io import write_dataset
from uqdrive.vehicle.montecarlo import simulate_ensemble
from uqdrive.vehicle.noise import add_noise
from uqdrive.settings import Settings

SETS = {
    "all": (("psi", "psi_dot", "beta", "y", "a_y"), False),
    "IMU only": (("psi_dot", "a_y"), False),
    "IMU + speed profile": (("psi_dot", "a_y"), True),
}
BRAKING = {"start_kmh": 80.0, "end_kmh": 50.0, "t_start": 1.0, "duration": 2.5}


def base_config():
    cfg = load_config(None)
    cfg["time"] = {"t_end": 4.0, "dt": 0.05, "step": 0.05}
    cfg["wind"]["sigma"] = 0.0
    return cfg


def one(cfg, channels, braking, n, seed, folder):
    data_cfg = copy.deepcopy(cfg)
    if braking:
        data_cfg["montecarlo"]["speed_profile"] = dict(BRAKING)
    ds = simulate_ensemble(Settings.from_config(data_cfg), "lst", samples=n, seed=seed)
    rng = np.random.default_rng(seed + 1)
    ds = ds.drop_vars([c for c in ("psi", "psi_dot", "beta", "y", "a_y", "spun") if c not in channels])
    for c in channels:
        ds[c] = ds[c].copy(data=add_noise(ds[c].values, 0.01, rng))
    path = folder / f"d{seed}_{n}.nc"
    write_dataset(ds, path)
    start = copy.deepcopy(cfg)
    start["uncertainty"]["mu"].update(mean=0.8, std=0.3)
    start["identification"]["optimiser"] = "gauss_newton"
    out = identify_file(start, path, "std", None, 0, folder / f"o{seed}_{n}")
    return out


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--replicates", type=int, default=2)
    parser.add_argument("--counts", default="10,20,40,100,1000")
    args = parser.parse_args()
    counts = [int(c) for c in args.counts.split(",")]
    cfg = base_config()
    truth = (cfg["uncertainty"]["mu"]["mean"], cfg["uncertainty"]["mu"]["std"])
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for n in counts:  # every channel set at few runs first: the cheap, telling cells
            for name, (channels, braking) in SETS.items():
                t0 = time.perf_counter()
                outs = [one(cfg, channels, braking, n, 100 + r, Path(tmp)) for r in range(args.replicates)]
                err_m = np.mean([abs(o["mu"][0] - truth[0]) for o in outs])
                err_s = np.mean([abs(o["mu"][1] - truth[1]) for o in outs])
                se_m = np.mean([o["standard_errors"]["mu"][0] for o in outs])
                se_s = np.mean([o["standard_errors"]["mu"][1] for o in outs])
                conv = sum(o["converged"] for o in outs)
                rows.append((name, n, err_m, se_m, err_s, se_s, conv, time.perf_counter() - t0))
                print(json.dumps({"set": name, "runs": n, "mu_mean_error": err_m, "mu_mean_se": se_m, "mu_std_error": err_s,
                                  "mu_std_se": se_s, "converged": f"{conv}/{len(outs)}", "seconds": round(rows[-1][-1], 1)}), flush=True)
    print(f"\n| channels | runs | mu mean: error | mu mean: SE | mu std: error | mu std: SE | converged |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    for name, n, em, sm, es, ss, conv, _ in sorted(rows, key=lambda r: (list(SETS).index(r[0]), r[1])):
        print(f"| {name} | {n} | {em:.4f} | {sm:.4f} | {es:.4f} | {ss:.4f} | {conv}/{args.replicates} |")
    print(f"\n(error: mean |estimate - truth| over {args.replicates} seeds, truth mu N{truth}; the sampling error of the "
          "runs' own mean, 0.2/sqrt(n), is included)")


if __name__ == "__main__":
    main()

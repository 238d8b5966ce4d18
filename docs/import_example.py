"""The worked example of the import guide, run at every docs build: a test day's logs made by an
independent simulator and asammdf, imported and identified by uqdrive, the results written as Markdown.
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import shlex
import tempfile
import warnings
from pathlib import Path

import numpy as np
import yaml

# -- the test day: 40 runs of a sedan, each logged on its own, as a data logger would --------------
# An independent linear single-track model (scipy's solve_ivp), not uqdrive's: mass, yaw inertia,
# axle positions and cornering stiffnesses of the packaged vehicle file rajamani_sedan.
M, I_Z, L_F, L_R, C_F, C_R = 1573.0, 2873.0, 1.1, 1.58, 160000.0, 160000.0
SPEED = 25.0                 # m/s (90 km/h)
RATIO = 15.3                 # hand-wheel angle per road-wheel angle of the steering robot's car
RATES = {"SteeringWheelAngle": 100.0, "YawRate": 50.0, "LatAcc": 100.0, "VehicleSpeed": 20.0}  # Hz
MU_MEAN, MU_STD, RUNS = 1.0, 0.15, 40


def steering(tau):
    """Road-wheel angle (rad) the robot steers, tau s after it starts: two sines in a 6 s window."""
    ramp = np.clip(np.minimum(tau, 6.0 - tau) / 0.5, 0.0, 1.0)
    return np.deg2rad(1.0) * np.sin(0.5 * np.pi * ramp) ** 2 * (np.sin(np.pi * tau) + 0.6 * np.sin(2.4 * np.pi * tau))


def drive(mu):
    """Yaw rate (rad/s) and lateral acceleration (m/s^2) of the runs with friction ``mu`` (shape
    (n,)) as functions of manoeuvre time: one solve_ivp over every run's side slip and yaw rate."""
    from scipy.integrate import solve_ivp

    n = mu.size

    def forces(t, beta, r):
        return mu * C_F * (steering(t) - beta - L_F * r / SPEED), mu * C_R * (-beta + L_R * r / SPEED)

    def rhs(t, x):
        F_f, F_r = forces(t, x[:n], x[n:])
        return np.concatenate([(F_f + F_r) / (M * SPEED) - x[n:], (L_F * F_f - L_R * F_r) / I_Z])

    sol = solve_ivp(rhs, (0.0, 12.0), np.zeros(2 * n), method="DOP853", rtol=1e-9, atol=1e-12, dense_output=True)

    def state(i, tau):
        x = np.where(tau > 0, sol.sol(np.clip(tau, 0.0, 12.0)), 0.0)
        return x[i], x[n + i]

    def lateral_acceleration(i, tau):
        beta, r = state(i, tau)
        return (mu[i] * C_F * (steering(tau) - beta - L_F * r / SPEED) + mu[i] * C_R * (-beta + L_R * r / SPEED)) / M

    return (lambda i, tau: state(i, tau)[1]), lateral_acceleration


def make_logs(folder: Path, seed: int = 2) -> np.ndarray:
    """One MDF4 file per run in ``folder``: hand-wheel degrees, deg/s, g on a lateral axis to the
    right, km/h, each channel at its own rate with 1 % noise, the recording started by hand 0.5-2 s
    before the robot steers. Returns the friction coefficient of each run."""
    from asammdf import MDF, Signal

    rng = np.random.default_rng(seed)
    mus = rng.normal(MU_MEAN, MU_STD, RUNS)
    yaw_rate, a_y = drive(mus)
    for i in range(RUNS):
        lead = rng.uniform(0.5, 2.0)
        mdf = MDF(version="4.10")
        for name, rate in RATES.items():
            t = np.arange(0.0, 12.0, 1.0 / rate)
            tau = t - lead
            x = {"SteeringWheelAngle": np.rad2deg(steering(tau)) * RATIO, "YawRate": np.rad2deg(yaw_rate(i, tau)),
                 "LatAcc": -a_y(i, tau) / 9.80665, "VehicleSpeed": np.full(t.size, SPEED * 3.6)}[name]
            if name != "VehicleSpeed":
                x = x + 0.01 * np.std(x) * rng.standard_normal(t.size)
            unit = {"SteeringWheelAngle": "deg", "YawRate": "deg/s", "LatAcc": "g", "VehicleSpeed": "km/h"}[name]
            mdf.append([Signal(x, t, name=name, unit=unit)])
        mdf.save(folder / f"run{i:02d}.mf4", overwrite=True)
        mdf.close()
    return mus


CHANNEL_MAP = """\
psi_dot: {channel: YawRate, units: deg/s}
a_y: {channel: LatAcc, units: g, sign: -1}        # the logger's lateral axis points right
delta: {channel: SteeringWheelAngle, units: deg, steering_ratio: 15.3}
v: {channel: VehicleSpeed, units: km/h}
"""
# l_f is the vehicle file's and there is no wind on the test day: both declared known
KNOWN = {"uncertainty": {"l_f": {"std": 0.0}, "F_w_mean": {"low": 0.0, "high": 0.0}}}


def _run(argv: list[str], shown: list[str], keep: int | None = None) -> str:
    """Run `uqdrive ARGV`; a console block with the command as ``shown`` and its output."""
    from uqdrive.cli.main import main

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err), warnings.catch_warnings():
        code = main(argv)
    if code != 0:
        raise RuntimeError(f"uqdrive {' '.join(argv)} failed: {err.getvalue()}")
    lines = (out.getvalue() + err.getvalue()).splitlines()
    if keep is not None and len(lines) > 2 * keep + 1:
        lines = lines[:keep] + [f"... ({len(lines) - 2 * keep} more runs)"] + lines[-keep:]
    return "```console\n$ uqdrive " + " ".join(shown) + "\n" + "\n".join(lines) + "\n```\n"


def write_example(target: Path) -> None:
    """Make the logs, import them, identify, and write the example's Markdown to ``target``."""
    import xarray as xr

    from uqdrive.config import default_config_text

    config = yaml.safe_load(default_config_text())
    for section, values in KNOWN["uncertainty"].items():
        config["uncertainty"][section].update(values)
    cwd = os.getcwd()
    with tempfile.TemporaryDirectory() as tmp:
        os.chdir(tmp)
        try:
            Path("logs").mkdir()
            mus = make_logs(Path("logs"))
            Path("map.yaml").write_text(CHANNEL_MAP)
            Path("known.yaml").write_text(yaml.safe_dump(config))
            logs = sorted(str(p) for p in Path("logs").glob("*.mf4"))
            imported = _run(["import", *logs, "--channels", "map.yaml", "--dt", "0.02", "--out", "day1.nc"],
                            ["import", "logs/*.mf4", "--channels", "map.yaml", "--dt", "0.02", "--out", "day1.nc"], keep=3)
            with xr.open_dataset("day1.nc") as ds:
                offsets = np.array(list(json.loads(ds.attrs["import_offsets"]).values()))
                n_time, dt = ds.sizes["time"], float(ds.attrs["import_dt"])
            argv = ["identify", "day1.nc", "--config", "known.yaml", "--vehicle", "rajamani_sedan", "--m-load", "0", "--out", "fit"]
            identified = _run(argv, argv)
            estimate = json.loads(Path("fit/estimate.json").read_text())
        finally:
            os.chdir(cwd)
    mean, std = estimate["mu"]
    gof = estimate["goodness_of_fit"]
    text = [
        "The map, `map.yaml`:\n", "```yaml\n" + CHANNEL_MAP + "```\n",
        "Import the 40 logs onto the yaw rate's 50 Hz grid:\n", imported,
        f"The offsets span {offsets.min():.3f} to {offsets.max():.3f} s (the hand-started recordings); the ensemble "
        f"holds {n_time} points of {dt:g} s. `known.yaml` is the default config with `uncertainty.l_f.std: 0` and "
        "`uncertainty.F_w_mean: {low: 0, high: 0}` (the car's l_f is its file's, and the test day had no wind); the "
        "file's mass is the car as driven, so `--m-load 0`:\n",
        identified,
        "| mu | mean | std |\n|---|---:|---:|\n"
        f"| the 40 runs' own values | {mus.mean():.4f} | {mus.std(ddof=1):.4f} |\n"
        f"| identified from the logs | {mean:.4f} | {std:.4f} |\n"
        f"| difference | {mean - mus.mean():+.4f} | {std - mus.std(ddof=1):+.4f} |\n",
        f"The misfit is {gof['ratio']:.2f} times the noise (99 % threshold {gof['threshold'] / gof['expected']:.2f}): "
        f"the linear model of the sedan {'explains' if gof['passed'] else 'does not explain'} the runs, "
        f"and the fit {'converged' if estimate['converged'] else 'did not converge'}.\n",
    ]
    target.parent.mkdir(parents=True, exist_ok=True)
    target.write_text("\n".join(text), encoding="utf-8")


if __name__ == "__main__":
    write_example(Path(__file__).parent / "api" / "generated" / "import_example.md")

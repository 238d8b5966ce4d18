"""A car braking through a slalom, recorded as an IMU records it, for the tests and benchmark of
discover's default candidates: the hidden-effect reality (code apart from the model's) with the
load moving to the front axle as the car brakes, and the thesis car's vehicle file with a height.
"""

from __future__ import annotations

from importlib.resources import files
from pathlib import Path

import yaml

#: The speed falls 22 -> 16 m/s at -2 m/s^2 (keywords of uqdrive.studies.manoeuvres.braking_in_turn_speed).
SPEED = {"start_kmh": 79.2, "end_kmh": 57.6, "t_brake": 2.0, "duration": 3.0}
SLALOM = {"amplitude_deg": 4.0, "period": 4.0}
#: The reality's centre-of-gravity height (m), the runs, the root seed and the recorded channels.
HEIGHT, RUNS, SEED, IMU = 0.61, 40, 7, ("psi_dot", "a_y")
#: The height the car's vehicle file states (m): near the reality's, not equal to it.
FILE_HEIGHT = 0.55
#: The reduced discover settings of the tests: 6 s on a 0.02 s grid (the braking from 2 to 5 s),
#: fewer realisations, replicates and times (each at the schema's floor or above it), no posterior.
QUICK_TIME = {"t_end": 6.0, "dt": 0.02, "step": 0.01}
QUICK = {"model_samples": 120, "nonlinear_samples": 50, "bootstrap": 30, "max_times": 30, "top": 2, "posterior": {"enabled": False}}


def vehicle_file(folder: Path, cg_height: float | None = FILE_HEIGHT) -> Path:
    """The packaged thesis car's vehicle file in ``folder``, with ``cg_height`` (m) unless None."""
    car = yaml.safe_load(files("uqdrive").joinpath("vehicles/thesis.yaml").read_text())
    if cg_height is not None:
        car["cg_height"] = cg_height
    path = Path(folder) / ("car.yaml" if cg_height is not None else "car_without_height.yaml")
    path.write_text(yaml.safe_dump(car, sort_keys=False))
    return path


def quick(config: dict) -> dict:
    """``config`` with the tests' reduced time grid and discover settings (its candidates kept)."""
    config["time"].update(QUICK_TIME)
    config["discrepancy"].update(QUICK)
    return config


def braking_runs(config, samples: int = RUNS, seed: int = SEED):
    """The ensemble (psi_dot, a_y and the speed v over time) on ``config``'s car and time grid."""
    from uqdrive.studies.hidden_effects import HiddenEffectCase, generate

    case = HiddenEffectCase("braking_slalom", "longitudinal_load_transfer", HEIGHT, "slalom", SLALOM, samples=samples, seed=seed, speed=SPEED)
    return generate(config, case, channels=IMU)

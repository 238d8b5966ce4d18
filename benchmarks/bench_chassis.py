"""Benchmark: the numerically integrated chassis models of discover's fits (uqdrive.vehicle.
track_extended) as a Jacobian asks for them: a point and its forward-difference neighbours
(six distribution parameters plus the effect's), 150 realisations each on a 10 s slalom at
19.4 m/s (the `--quick` non-linear realisations), simulated in one batch (simulate_many: the
pairs of one kind share an RK4 pass) against one simulate per pair (the baseline, in the same
run). Prints a table of seconds (best of three) and ratios; both give the same numbers, bit for
bit (checked here too).

    python benchmarks/bench_chassis.py [--samples 150] [--repeats 3]
"""

from __future__ import annotations

import argparse

import numpy as np

from timing import best_of
from uqdrive.config import load_config
from uqdrive.vehicle.augmented import AugmentedSimulator
from uqdrive.vehicle.effects import EFFECTS, ModelStructure
from uqdrive.settings import Settings

THETA = np.array([1.0, 0.2, 1.55, 0.2, -400.0, 400.0])


def _structures():
    tyre = EFFECTS["tyre_saturation"].augment(ModelStructure(), [0.97])
    return {
        "longitudinal_load_transfer": (EFFECTS["longitudinal_load_transfer"], tyre, [0.55]),
        "lateral_load_transfer": (EFFECTS["lateral_load_transfer"], tyre, [0.55, -0.3]),
        "tyre_relaxation": (EFFECTS["tyre_relaxation"], tyre, [0.4]),
        "roll_steer": (EFFECTS["roll_steer"], tyre, [0.35, 2.4, 0.6]),
        "roll_steer + tyre_relaxation": (EFFECTS["roll_steer"], EFFECTS["tyre_relaxation"].augment(tyre, [0.4]), [0.35, 2.4, 0.6]),
    }


def jacobian_pairs(effect, base, values):
    """The (theta, structure) pairs of a forward-difference Jacobian at (THETA, values)."""
    values = np.asarray(values, float)
    thetas, structures = [THETA], [effect.augment(base, values)]
    for i in range(THETA.size):
        thetas.append(THETA + 1e-4 * np.maximum(np.abs(THETA[i]), 1.0) * np.eye(THETA.size)[i])
        structures.append(structures[0])
    for i in range(values.size):
        thetas.append(THETA)
        structures.append(effect.augment(base, values + 1e-4 * np.maximum(np.abs(values[i]), 0.1) * np.eye(values.size)[i]))
    return thetas, structures


def slalom_simulator(samples: int):
    """The benchmark's simulator: ``samples`` realisations on a 3 deg, 0.25 Hz slalom of 10 s at
    19.4 m/s, the default car with the cg_height and track_width the chassis terms need."""
    config = load_config(None)
    config["vehicle"].update(cg_height=0.55, track_width=1.6)
    t = np.arange(1001) * 0.01
    return AugmentedSimulator.drawn(Settings.from_config(config), t, np.deg2rad(3.0) * np.sin(2 * np.pi * t / 4.0), 19.4, samples,
                                    np.random.default_rng(7), stride=2)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=150)
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args(argv)
    sim = slalom_simulator(args.samples)
    print("| structure | pairs | one simulate per pair (s) | simulate_many (s) | ratio | same numbers |")
    print("|---|---|---|---|---|---|")
    for name, (effect, base, values) in _structures().items():
        thetas, structures = jacobian_pairs(effect, base, values)
        t_one, one = best_of(lambda: [sim.simulate(th, s) for th, s in zip(thetas, structures)], args.repeats)
        t_many, many = best_of(lambda: sim.simulate_many(thetas, structures), args.repeats)
        same = all(np.array_equal(a, b) for a, b in zip(one, many))
        print(f"| {name} | {len(thetas)} | {t_one:.2f} | {t_many:.2f} | {t_one / t_many:.2f} | {'yes' if same else 'NO'} |", flush=True)


if __name__ == "__main__":
    main()

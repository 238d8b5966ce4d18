"""Linear models along a speed profile (the detection table's IMU + speed-profile columns): a fit's
Jacobian, the centre and its six difference neighbours, simulated pair by pair as a call of its own
each (the gust product computed anew per call) against one batched call (`simulate_many`: one RK4
pass, the gust product kept), in CPU seconds; the simulations must be equal bit for bit.

The simulator is discover's on the cell's data (`--cell`, case:channel_set:runs of the detection
table, default the slowest cell): 1000 model realisations, psi_dot and a_y while braking in the turn.
The two variants alternate `--repeats` times in one process after an untimed warm-up; CPU seconds
are the smallest of the repeats (other processes on the machine slow both alike).

`--discover` also runs discover on the cell with both variants (the per-pair one by patching the
simulator's batching and gust product away) and checks that the verdicts are equal, number for number.

Usage: python benchmarks/bench_profile_batch.py [--cell actuator_lag_200ms:imu_speed:20] [--repeats 3] [--discover]
"""

import argparse
import dataclasses
import time

import numpy as np

from timing import without
from uqdrive.config import load_config
from uqdrive.inference.discrepancy import DiscrepancyFinder
from uqdrive.inference.discrepancy.comparison import prepare_measured, speed_profile
from uqdrive.rng import rng_stream
from uqdrive.settings import Settings
from uqdrive.studies.discrepancy import BRAKING, CHANNEL_SETS
from uqdrive.studies.hidden_effects import benchmark_cases, generate
from uqdrive.vehicle.augmented import AugmentedSimulator
from uqdrive.vehicle.effects import ModelStructure


def per_pair(sim, thetas, structures):
    """The pairs as calls of their own, each computing its gust product anew."""
    out = []
    for th, s in zip(thetas, structures):
        sim._gust_products.clear()
        out.append(sim.simulate(th, s))
    return out


def cpu(fn):
    clock = time.process_time()
    result = fn()
    return time.process_time() - clock, result


def discover(settings, data, batched: bool):
    """CPU seconds and verdict of one discover; ``batched`` False patches the batching and the kept gust products away."""
    profile_many, gusts = AugmentedSimulator._profile_many, AugmentedSimulator._gusts
    if not batched:
        AugmentedSimulator._profile_many = lambda self, thetas, structures: [self.simulate(th, s) for th, s in zip(thetas, structures)]
        AugmentedSimulator._gusts = lambda self, coeffs, f_half, t_half: np.ascontiguousarray((coeffs @ f_half).T)
    try:
        seconds, finder = cpu(lambda: DiscrepancyFinder(settings, posterior=False).fit(data))
        return seconds, without(finder.verdict_)
    finally:
        AugmentedSimulator._profile_many, AugmentedSimulator._gusts = profile_many, gusts


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--cell", default="actuator_lag_200ms:imu_speed:20", help="case:channel_set:runs")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--discover", action="store_true", help="also discover on the cell with both variants")
    args = parser.parse_args(argv)
    config = load_config(None)
    settings = Settings.from_config(config)
    name, channel_set, runs = args.cell.split(":")
    channels, braking = CHANNEL_SETS[channel_set]
    case = {c.name: c for c in benchmark_cases(config)}[name]
    data = generate(config, dataclasses.replace(case, samples=int(runs), speed=BRAKING if braking else {}), channels=channels)
    m = prepare_measured(data, settings.spin, settings.discover.max_times)
    speed = speed_profile(data)
    if speed is None:
        raise SystemExit(f"{args.cell}: the cell's data hold no speed profile (take an imu_speed cell)")
    n = settings.discover.model_samples
    sim = AugmentedSimulator.drawn(settings, data["time"].values, data["delta"].values, float(np.mean(speed)), n,
                                   rng_stream(settings.seed, "discrepancy_model"), stride=m.stride, channels=m.channels, speed=speed)
    theta = np.asarray(settings.layout.start, float)
    thetas = [theta] + [theta + 1e-4 * np.maximum(np.abs(theta), settings.layout.scales) * np.eye(6)[i] for i in range(6)]
    structures = [ModelStructure()] * len(thetas)
    sim.simulate(theta, structures[0])  # warm-up; the batched variant then finds the centre's gust product, as a fit's Jacobian does
    best = {}
    for _ in range(args.repeats):
        for variant, fn in (("per pair", lambda: per_pair(sim, thetas, structures)), ("batched", lambda: sim.simulate_many(thetas, structures))):
            seconds, result = cpu(fn)
            if variant not in best or seconds < best[variant][0]:
                best[variant] = (seconds, result)
    same = all(np.array_equal(a, b) for a, b in zip(best["per pair"][1], best["batched"][1]))
    old, new = best["per pair"][0], best["batched"][0]
    print(f"{args.cell}: {len(thetas)} linear models x {n} realisations, {sim.time.size - 1} steps along the speed profile")
    print(f"| variant | CPU s | ratio |\n|---|---|---|\n| per pair | {old:.3f} | 1.00 |\n| batched | {new:.3f} | {old / new:.2f}x |")
    print(f"bit for bit: {same}")
    if args.discover:
        rows = {batched: discover(settings, data, batched) for batched in (False, True)}
        print(f"discover: per pair {rows[False][0]:.1f} CPU s, batched {rows[True][0]:.1f} CPU s ({rows[False][0] / rows[True][0]:.2f}x); "
              f"verdict {rows[True][1]['effect']}, equal number for number: {rows[False][1] == rows[True][1]}")
    if not same:
        raise SystemExit("the batched simulations differ from the per-pair ones")


if __name__ == "__main__":
    main()

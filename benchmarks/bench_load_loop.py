"""Benchmark: the chassis models' loads-forces loop compiled (uqdrive.vehicle.dynamics.load_newton) against
the NumPy loop (the baseline, in the same run): a Jacobian's pairs of each loaded chassis candidate
(six distribution parameters plus the effect's), 300 realisations each (discover's non-linear
realisations) on a 10 s slalom at 19.4 m/s, on the linear tyre and on the Magic Formula, simulated
in one batch (simulate_many). Prints a table of seconds (best of ``--repeats``), ratios, whether
the two give the same numbers bit for bit (a combination's first call, which compiles it or loads
it from numba's cache, is not timed).

    python benchmarks/bench_load_loop.py [--samples 300] [--repeats 2] [--json FILE]
"""

from __future__ import annotations

import argparse
import json

import numpy as np

from bench_chassis import jacobian_pairs, slalom_simulator
from timing import best_of
from uqdrive.vehicle import track_extended
from uqdrive.vehicle.effects import EFFECTS, ModelStructure

#: The loaded chassis candidates at sizes a four-wheel car shows.
LOADED = {"lateral_load_transfer": [0.55, -0.3], "longitudinal_load_transfer": [0.55], "combined_slip": [0.8, 0.4],
          "load_sensitive_tyre": [0.5, -0.2]}


def _cases():
    tyres = {"linear": ModelStructure(), "magic_formula": EFFECTS["tyre_saturation"].augment(ModelStructure(), [0.97])}
    for tyre, base in tyres.items():
        for name, values in LOADED.items():
            if tyre == "magic_formula" and name == "load_sensitive_tyre":
                continue  # its stiffness moves the curve each step: the NumPy loop either way
            yield tyre, name, EFFECTS[name], base, values
    relaxed = EFFECTS["tyre_relaxation"].augment(tyres["linear"], [0.4])
    yield "linear", "lateral_load_transfer + tyre_relaxation", EFFECTS["lateral_load_transfer"], relaxed, LOADED["lateral_load_transfer"]


def _run(sim, thetas, structures, compiled: bool, repeats: int):
    track_extended.COMPILED_LOOP = compiled
    try:
        return best_of(lambda: sim.simulate_many(thetas, structures), repeats)
    finally:
        track_extended.COMPILED_LOOP = True


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=300)
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--json", default=None, help="write the record here (docs/measurements/benchmarks_load_loop.json)")
    ap.add_argument("--machine", default="this machine")
    args = ap.parse_args(argv)
    sim = slalom_simulator(args.samples)
    rows = []
    print("| tyre | structure | pairs | NumPy loop (s) | compiled loop (s) | ratio | same bits |")
    print("|---|---|---|---|---|---|---|")
    for tyre, name, effect, base, values in _cases():
        thetas, structures = jacobian_pairs(effect, base, values)
        _run(sim, thetas[:1], structures[:1], True, 1)  # compiles (or loads the cache of) this combination of terms: not timed
        t_np, ref = _run(sim, thetas, structures, False, args.repeats)
        t_c, out = _run(sim, thetas, structures, True, args.repeats)
        same = all(np.array_equal(a, b) for a, b in zip(ref, out))
        rows.append({"tyre": tyre, "structure": name, "pairs": len(thetas), "numpy_s": round(t_np, 3), "compiled_s": round(t_c, 3),
                     "same": same})
        print(f"| {tyre} | {name} | {len(thetas)} | {t_np:.2f} | {t_c:.2f} | {t_np / t_c:.2f} | {'yes' if same else 'NO'} |",
              flush=True)
    if args.json:
        record = {"command": "python benchmarks/bench_load_loop.py", "machine": args.machine, "realisations": args.samples,
                  "duration_s": 10, "repeats": args.repeats, "rows": rows}
        with open(args.json, "w") as fh:
            json.dump(record, fh, indent=1)
            fh.write("\n")


if __name__ == "__main__":
    main()

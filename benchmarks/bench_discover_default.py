"""`discover` with the packaged default config (every registered candidate) on two cases, its CPU
seconds (time.process_time) and verdict:

* `braking`: a car braking through a slalom, recorded as an IMU records it (yaw rate and lateral
  acceleration, 40 runs), its centre of gravity above the ground: the load moves to the front
  axle as it brakes. Made by the hidden-effect reality (uqdrive.studies.hidden_effects), code
  apart from the model's (tests/braking_runs.py); the car is the thesis car's vehicle file with a cg_height.
* `tour`: the README's tour, 200 runs of the non-linear model under the slalom, the packaged car.

`--candidates a,b,...` searches those instead (e.g. the reproduction's eight, to compare);
`--quick` the reduced settings of the tests (tests/braking_runs.py). Usage:

    python benchmarks/bench_discover_default.py --case braking [--candidates ...] [--quick]
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
import braking_runs as br  # noqa: E402


def main() -> None:
    import uqdrive
    from uqdrive.config import load_config

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--case", choices=("braking", "tour"), default="braking")
    ap.add_argument("--candidates", default=None, help="comma-separated candidates (default: the config's, all)")
    ap.add_argument("--quick", action="store_true", help="the test's reduced discover settings")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        car = br.vehicle_file(Path(tmp)) if args.case == "braking" else None
        config = load_config(None, vehicle=car)
        if args.quick:
            br.quick(config)
        runs = br.braking_runs(config) if args.case == "braking" else uqdrive.simulate("nlst", samples=200, config=config)
        candidates = None if args.candidates is None else args.candidates.split(",")
        clock, wall = time.process_time(), time.perf_counter()
        verdict = uqdrive.discover(runs, config=config, candidates=candidates)
        cpu, wall = time.process_time() - clock, time.perf_counter() - wall
    v = verdict.to_dict()
    print(verdict.summary())
    print(f"{args.case}: discover {cpu:.1f} CPU-s ({wall:.1f} s wall), candidates "
          f"{args.candidates or config['discrepancy']['candidates']}{' (quick)' if args.quick else ''}")
    for e in v["effects"]:
        print(f"  {e['effect']}: {json.dumps(e.get('parameters', {}))}, gap after {e.get('gap_after')}")
    for u in v["untestable"]:
        print(f"  untestable: {u['reason']}")
    print(f"  gap {v['gap_before']:.3g} -> {v['gap_after']:.3g}; stage seconds {json.dumps(v['evidence'].get('stage_seconds', {}))}")


if __name__ == "__main__":
    main()

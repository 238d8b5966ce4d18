"""Benchmark: `uqdrive import` of 40 recorded runs of 12 s (steering and lateral acceleration at
100 Hz, yaw rate 50 Hz, speed 20 Hz), as MDF4 files, CSV exports and dSPACE MAT files (v5 and
v7.3 alternating): the first call (which also builds pint's unit registry) and the best of three. Run: `make bench` or `python benchmarks/bench_import.py`.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np
from timing import best_of

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
import recorded_runs as rr  # noqa: E402

from uqdrive.recordings.importer import import_runs  # noqa: E402


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=40, help="recorded runs (default 40)")
    args = parser.parse_args(argv)
    rng = np.random.default_rng(0)
    runs = rr.record(rng.normal(1.0, 0.15, args.runs), 25.0, rng.uniform(0.5, 2.0, args.runs), rng=rng, noise=0.01)
    print(f"importing {args.runs} runs of {rr.RECORD:g} s:")
    with tempfile.TemporaryDirectory() as tmp:
        for label, suffixes in (("MDF4 (.mf4)", (".mf4",)), ("CSV (',' and ';' dialects)", (".csv", ".de.csv")),
                                ("MATLAB (dSPACE, v5 and v7.3)", (".mat", ".v73.mat"))):
            files = [rr.write(r, Path(tmp) / f"run{i:02d}{suffixes[i % len(suffixes)]}") for i, r in enumerate(runs)]
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                t0 = time.perf_counter()
                import_runs(files, rr.MAP)
                first = time.perf_counter() - t0
                seconds, ds = best_of(lambda: import_runs(files, rr.MAP))
            size = sum(f.stat().st_size for f in files) / 1e6
            print(f"  {label:28s} first call {first:5.2f} s, best of 3 {seconds:5.2f} s  ({size:.1f} MB of logs -> "
                  f"{ds.sizes['sample']} runs x {ds.sizes['time']} points)")


if __name__ == "__main__":
    main()

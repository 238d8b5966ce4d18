"""Benchmark: what a workflow job pays besides its computation, the Python start with the imports
of its script and the netCDF file it writes and its successors read (one measured benchmark
ensemble, written deflated as the package wrote it before and plain as `write_dataset` writes it).

    python benchmarks/bench_job_overhead.py [--repeats 5] [--json docs/measurements/benchmarks_job_overhead.json]

Each start is a fresh interpreter (`python -c "import ..."`, wall seconds, the median of
``--repeats``); the file times are the best of ``--repeats`` in this process.
"""

from __future__ import annotations

import argparse
import json
import platform
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import xarray as xr

from uqdrive.config import load_config
from uqdrive.io import read_ensemble, write_dataset
from uqdrive.studies.hidden_effects import benchmark_cases, generate

from timing import best_of

#: What a job's script imports (the discover job's, a figure job's), against a bare interpreter.
STARTS = {"bare interpreter": "pass", "discover job (uqdrive.cli.discover)": "import uqdrive.cli.discover",
          "figure job (matplotlib, xarray)": "import xarray, uqdrive.plots.figure"}
#: The encoding `write_dataset` used before: zlib level 4 with HDF5's byte shuffle (netCDF4's default with zlib).
DEFLATE = {"zlib": True, "complevel": 4, "shuffle": True}


def start_seconds(code: str, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-c", code], check=True)
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def file_rows(ds: xr.Dataset, folder: Path, repeats: int) -> list[dict]:
    rows = []
    for label, write in (("deflate (zlib 4, shuffle)", lambda p: ds.to_netcdf(p, engine="netcdf4", format="NETCDF4",
                                                                             encoding={n: DEFLATE for n in ds.data_vars})),
                         ("plain (write_dataset)", lambda p: write_dataset(ds, p))):
        path = folder / f"{len(rows)}.nc"
        write_s, _ = best_of(lambda: write(path), repeats)
        read_s, back = best_of(lambda: read_ensemble(path), repeats)
        assert all((back[n].values == ds[n].values).all() for n in ds.data_vars), "the file does not hold the ensemble"
        rows.append({"encoding": label, "write_s": round(write_s, 3), "read_s": round(read_s, 3), "mb": round(path.stat().st_size / 1e6, 1)})
    return rows


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--case", default="none_step", help="benchmark case whose measured ensemble is written (default none_step)")
    parser.add_argument("--machine", default=f"{platform.machine()} machine")
    parser.add_argument("--json", type=Path, default=None, help="write the record the benchmarks page renders")
    args = parser.parse_args(argv)
    starts = [{"job": label, "seconds": round(start_seconds(code, args.repeats), 2)} for label, code in STARTS.items()]
    for row in starts:
        print(f"start of a {row['job']:40s} {row['seconds']:5.2f} s")
    config = load_config(Path(__file__).resolve().parents[1] / "config" / "config.yaml")  # the reproduction's
    samples = config["discrepancy"]["benchmark"]["samples"]
    case = {c.name: c for c in benchmark_cases(config, samples=samples)}[args.case]
    ds = generate(config, case)
    with tempfile.TemporaryDirectory() as tmp:
        files = file_rows(ds, Path(tmp), args.repeats)
    for row in files:
        print(f"{args.case} ({ds.sizes['sample']} runs x {ds.sizes['time']} times), {row['encoding']:26s} write {row['write_s']:6.3f} s, "
              f"read {row['read_s']:6.3f} s, {row['mb']:5.1f} MB")
    if args.json:
        record = {"command": "python benchmarks/bench_job_overhead.py --json docs/measurements/benchmarks_job_overhead.json",
                  "machine": args.machine, "repeats": args.repeats, "starts": starts,
                  "file": {"case": args.case, "runs": ds.sizes["sample"], "times": ds.sizes["time"], "channels": len(ds.data_vars) - 1, "rows": files}}
        args.json.write_text(json.dumps(record, indent=1) + "\n")


if __name__ == "__main__":
    main()

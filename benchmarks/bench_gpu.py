"""Benchmark: the default config's NLST Monte Carlo ensemble on JAX (a GPU when JAX sees one)
against the NumPy path, in the same run: the kernel (states on the device), the kernel with the
copy to the host, the whole `simulate_ensemble` (its KLE given), the compile time, and the largest relative
difference between the two paths.

    PYTHONPATH=src python3 benchmarks/bench_gpu.py [--sizes 2000 20000 200000] [--numpy-max 20000] [--json PATH]

Needs numpy, scipy, xarray, pyyaml and jax only (no netCDF4, jsonschema, emcee, snakemake): a bare
GPU machine runs it from a checkout. Without a GPU the sizes default to 2000 (JAX's CPU build).
`--json docs/measurements/gpu.json` writes the file that docs/benchmarks.md renders.
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
import time
from pathlib import Path

import numpy as np

from timing import best_of
from uqdrive._yaml import load_yaml
from uqdrive.numerics.backend import float64, gpu_visible
from uqdrive.rng import rng_stream
from uqdrive.settings import Settings
from uqdrive.vehicle.accelerated.nlst import nlst_program
from uqdrive.vehicle.dynamics import EnsembleSimulator
from uqdrive.vehicle.montecarlo import NLST, _wind_modes, simulate_ensemble, wind_kle
from uqdrive.vehicle.single_track import VehicleParameters, steering_input
from uqdrive.vehicle.uncertainty import ParameterDistribution

REPO = Path(__file__).resolve().parents[1]


def _settings(path: Path) -> Settings:
    """The config's settings, validated where jsonschema is installed (the default config needs no
    merging, so its plain YAML gives the same settings)."""
    try:
        from uqdrive.config import load_config

        return Settings.from_config(load_config(path))
    except ImportError:
        return Settings.from_config(load_yaml(path.read_text()))


def _inputs(settings: Settings, n: int) -> tuple:
    """The arguments of the NLST kernels for n realisations, drawn as `simulate_ensemble` draws them."""
    kle = wind_kle(settings)
    dist = ParameterDistribution.from_settings(settings.uncertainty)
    draws = dist.from_germs(dist.sample_germs(rng_stream(settings.seed, "parameters"), n))
    xi = rng_stream(settings.seed, "wind").standard_normal((n, kle.n_modes))
    p = VehicleParameters.from_settings(settings, mu=draws["mu"], m_load=draws["m_load"], l_f=draws["l_f"])
    t = settings.time.fine(2)
    delta = steering_input(t, settings.steering.delta_max, settings.steering.period)
    return (p, delta, draws["F_w_mean"], _wind_modes(kle, settings.wind.sigma, xi), kle.eigenfunctions(t), settings.time,
            settings.wind.gust_yaw_moment)


def _relative_difference(x, ref) -> float:
    """Largest |x - ref| of each state over its largest |ref|, the worst state's (-)."""
    return float((np.abs(x - ref).max(axis=(1, 2)) / np.abs(ref).max(axis=(1, 2))).max())


def bench_size(settings: Settings, n: int, run_numpy: bool, whole: bool, repeats: int, unroll: int) -> dict:
    import jax

    args = _inputs(settings, n)
    row = {"runs": n}
    with float64():
        function, device_args = nlst_program(*args, unroll=unroll)
        t0 = time.perf_counter()
        compiled = function.lower(*device_args).compile()
        row["jax_compile_s"] = time.perf_counter() - t0
        jax.block_until_ready(compiled(*device_args))  # the first call also allocates
        row["jax_kernel_s"], states = best_of(lambda: jax.block_until_ready(compiled(*device_args)), repeats)
        row["jax_kernel_to_host_s"], on_host = best_of(lambda: np.asarray(compiled(*device_args)), min(repeats, 3))
        del states
    few = min(repeats, 3) if n <= 2000 else 1  # a 20000-run NumPy ensemble takes tens of seconds
    if run_numpy:
        p, delta, wind, coeffs, f_half, grid, _ = args
        simulator = EnsembleSimulator.driven(settings, grid, delta, f_half, p.v_c)
        row["numpy_kernel_s"], reference = best_of(lambda: simulator.realise(p, wind, coeffs, NLST), few)
        row["max_relative_difference"] = _relative_difference(on_host, reference)
        row["speedup_kernel"] = row["numpy_kernel_s"] / row["jax_kernel_s"]
    if whole:  # the KLE computed once, as a workflow job or a study passes it
        kle = wind_kle(settings)
        if gpu_visible():
            simulate_ensemble(settings, "nlst", samples=n, kle=kle, device="gpu")  # compiles this shape's program once
            row["jax_ensemble_s"], _ = best_of(lambda: simulate_ensemble(settings, "nlst", samples=n, kle=kle, device="gpu"), few)
        if run_numpy:
            row["numpy_ensemble_s"], _ = best_of(lambda: simulate_ensemble(settings, "nlst", samples=n, kle=kle, device="cpu"), few)
    return row


def machine() -> dict:
    """The device, JAX's version and platform, and the host's processor, for the record."""
    import jax

    dev = jax.devices()[0]
    return {"device": getattr(dev, "device_kind", str(dev)), "platform": jax.default_backend(), "jax": jax.__version__,
            "numpy": np.__version__, "python": platform.python_version(), "host_cpu": platform.processor() or platform.machine(),
            "date": time.strftime("%Y-%m-%d", time.gmtime())}


def _options() -> list[str]:
    """The command line's options without the JSON file's path (a machine's own folder)."""
    words = sys.argv[1:]
    return [w for i, w in enumerate(words) if w != "--json" and (i == 0 or words[i - 1] != "--json") and not w.startswith("--json=")]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--config", type=Path, default=REPO / "config" / "config.yaml")
    parser.add_argument("--sizes", type=int, nargs="+", default=None, help="ensemble sizes (default 2000 20000 200000 on a GPU, else 2000)")
    parser.add_argument("--numpy-max", type=int, default=20000, help="largest size the NumPy path is timed at")
    parser.add_argument("--whole-max", type=int, default=20000, help="largest size simulate_ensemble is timed at as a whole")
    parser.add_argument("--repeats", type=int, default=5, help="best of this many calls (NumPy: at most 3)")
    parser.add_argument("--unroll", type=int, default=1, help="output intervals per iteration of the compiled loop")
    parser.add_argument("--json", type=Path, default=None, help="write the results to this JSON file")
    args = parser.parse_args()
    settings = _settings(args.config)
    sizes = args.sizes or ([2000, 20000, 200000] if gpu_visible() else [2000])
    info = machine()
    grid = settings.time
    print(f"NLST ensembles of {grid.t_end:g} s, RK4 at {grid.step * 1e3:g} ms ({grid.n_out * grid.substeps} steps); "
          f"JAX {info['jax']} on {info['platform']} ({info['device']}), float64; best of {args.repeats}", flush=True)
    print(f"{'runs':>7} {'compile [s]':>11} {'JAX kernel [s]':>14} {'+ to host [s]':>13} {'NumPy kernel [s]':>16} "
          f"{'speed-up':>8} {'JAX ensemble [s]':>16} {'NumPy ensemble [s]':>18} {'max rel diff':>12}", flush=True)
    rows = []
    for n in sizes:
        row = bench_size(settings, n, n <= args.numpy_max, n <= args.whole_max, args.repeats, args.unroll)
        rows.append(row)
        cell = lambda key, fmt: format(row[key], fmt) if key in row else "-"  # noqa: E731
        print(f"{n:7d} {cell('jax_compile_s', '11.2f')} {cell('jax_kernel_s', '14.4f')} {cell('jax_kernel_to_host_s', '13.4f')} "
              f"{cell('numpy_kernel_s', '16.3f')} {cell('speedup_kernel', '7.3g')}x {cell('jax_ensemble_s', '16.3f')} "
              f"{cell('numpy_ensemble_s', '18.3f')} {cell('max_relative_difference', '12.1e')}", flush=True)
    if args.json:
        record = {"machine": info, "t_end_s": grid.t_end, "step_s": grid.step, "steps": grid.n_out * grid.substeps,
                  "repeats": args.repeats, "unroll": args.unroll, "command": " ".join(["PYTHONPATH=src python3 benchmarks/bench_gpu.py", *_options()]),
                  "rows": rows}
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(record, indent=1) + "\n")
        print(f"wrote {args.json}")


if __name__ == "__main__":
    main()

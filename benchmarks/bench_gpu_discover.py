"""Discover on a GPU against the CPU: one four-wheel case (the generator of bench_four_wheel.py,
every candidate, no posterior) discovered with device gpu twice, each in a process of its own
(cold: an empty JAX compilation cache; warm: the next process loading what the first compiled),
and on the CPU with ``--jobs``; wall and CPU seconds, the JAX programs run, the passes' seconds
(compilation or loading included) and the host's rest, whether the verdicts agree.

    PYTHONPATH=src python3 benchmarks/bench_gpu_discover.py --out DIR [--case fw_step_060] [--samples 500]
        [--jobs auto] [--json FILE] [--jax-cpu]

``--jax-cpu``: JAX's CPU build stands in for the GPU (checks this script on a machine without
one; its times say nothing of a GPU). The case is kept as a pickled Dataset (no netCDF library needed).
The target (issue 45): a four-wheel discover on a GPU in at most 30 s, the same verdict as the CPU's.
"""

import argparse
import json
import os
import pickle
import resource
import shutil
import subprocess
import sys
import time
from pathlib import Path

from bench_four_wheel import CG_HEIGHT, TRACK_WIDTH
from uqdrive.config import load_config


def _config() -> dict:
    config = load_config(None)
    config["vehicle"].update(cg_height=CG_HEIGHT, track_width=TRACK_WIDTH)
    return config


def _case(out: Path, name: str, samples: int) -> Path:
    """The case's ensemble, generated once into ``out``/NAME.pkl."""
    from uqdrive.settings import Settings
    from uqdrive.studies.four_wheel import amplitude_for, four_wheel_cases, generate, steady_limit
    from uqdrive.vehicle.four_wheel import FourWheelCar

    path = out / f"{name}.pkl"
    if not path.exists():
        config = _config()
        car = FourWheelCar.from_vehicle(Settings.from_config(config).vehicle)
        case = next(c for c in four_wheel_cases(config, samples=samples) if c.name == name)
        ds = generate(config, case, amplitude_for(config, car, case, steady_limit(config, car)), car)
        path.write_bytes(pickle.dumps(ds))
    return path


def _one_run(data: Path, device: str, jobs: str, jax_cpu: bool) -> dict:
    """One timed discover in this process: its verdict's effects and gaps, seconds and the programs."""
    import uqdrive
    from uqdrive.cli.validation import compilation_cache
    from uqdrive.numerics import backend

    if jax_cpu:
        backend.gpu_visible = lambda: True  # noqa: E731 (JAX's CPU build stands in)
    passes = [0, 0.0]
    if device == "gpu":
        compilation_cache()
        from uqdrive.vehicle.accelerated import chassis_ensemble

        integrate = chassis_ensemble.integrate_chassis_jax

        def timed(*args, **kwargs):  # the device's share: each pass from its inputs to its states on the host
            t0 = time.perf_counter()
            try:
                return integrate(*args, **kwargs)
            finally:
                passes[0] += 1
                passes[1] += time.perf_counter() - t0

        chassis_ensemble.integrate_chassis_jax = timed
    ds = pickle.loads(data.read_bytes())
    wall = time.perf_counter()
    verdict = uqdrive.discover(ds, config=_config(), candidates="all", posterior=False, device=device, jobs=jobs)
    wall = time.perf_counter() - wall
    usage = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    row = {"device": device, "jobs": jobs, "wall_s": round(wall, 2), "cpu_s": round(sum(u.ru_utime + u.ru_stime for u in usage), 1),
           "effects": [e["effect"] for e in verdict.document["effects"]], "gap_before": verdict.document.get("gap_before"),
           "gap_after": verdict.document.get("gap_after")}
    if device == "gpu":
        import jax

        from uqdrive.vehicle.accelerated import chassis_ensemble

        row.update(programs=chassis_ensemble.programs_compiled(), jax_device=str(jax.devices()[0]), passes=passes[0],
                   passes_s=round(passes[1], 2), host_s=round(wall - passes[1], 2))
    return row


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", required=True, type=Path)
    ap.add_argument("--case", default="fw_step_060")
    ap.add_argument("--samples", type=int, default=500)
    ap.add_argument("--jobs", default="auto", help="the CPU run's --jobs (default auto)")
    ap.add_argument("--json", type=Path, default=None)
    ap.add_argument("--jax-cpu", action="store_true", help="JAX's CPU build stands in for the GPU")
    ap.add_argument("--one-run", nargs=2, metavar=("DEVICE", "JOBS"), help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    data = _case(args.out, args.case, args.samples)
    if args.one_run:
        print(json.dumps(_one_run(data, *args.one_run, args.jax_cpu)))
        return
    cache = args.out / "jax_cache"
    shutil.rmtree(cache, ignore_errors=True)
    env = {**os.environ, "JAX_COMPILATION_CACHE_DIR": str(cache)}
    rows = []
    for label, device, jobs in (("gpu, cold", "gpu", "1"), ("gpu, warm", "gpu", "1"), ("cpu", "cpu", args.jobs)):
        command = [sys.executable, __file__, "--out", str(args.out), "--case", args.case, "--samples", str(args.samples),
                   "--one-run", device, jobs] + (["--jax-cpu"] if args.jax_cpu else [])
        run = subprocess.run(command, capture_output=True, text=True, env=env)
        if run.returncode:
            sys.exit(f"{label}: {run.stderr.strip().splitlines()[-1] if run.stderr.strip() else run.returncode}")
        rows.append({"run": label, **json.loads(run.stdout.strip().splitlines()[-1])})
        print(json.dumps(rows[-1]), flush=True)
    same = all((r["effects"], r["gap_before"], r["gap_after"]) == (rows[-1]["effects"], rows[-1]["gap_before"], rows[-1]["gap_after"])
               for r in rows)
    record = {"case": args.case, "samples": args.samples, "jax_cpu": args.jax_cpu, "date": time.strftime("%Y-%m-%d"),
              "command": "PYTHONPATH=src python3 benchmarks/bench_gpu_discover.py " + " ".join(argv or sys.argv[1:]),
              "rows": rows, "same_verdict": same}
    print(f"same verdict on every run: {same}")
    if args.json is not None:
        args.json.write_text(json.dumps(record, indent=1) + "\n")


if __name__ == "__main__":
    main()

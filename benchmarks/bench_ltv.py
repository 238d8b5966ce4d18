"""Benchmark: the linear single-track model's RK4 pass along a speed profile (the detection
table's IMU + speed-profile cells), NumPy against the compiled kernel, in the same run.

old: ``rk4_fixed_step_into(LinearTrackRHS)``, the NumPy reference, 17 array operations per stage;
new: :func:`uqdrive.vehicle.dynamics.ltv_rk4.rk4_linear_track`, every step and realisation in one
compiled loop. A 10 s run braking 70 -> 45 km/h (from 3 s to 6 s), RK4 at 5 ms, psi_dot and beta
alone (the cells' channels hold neither psi nor y), per-realisation mu, load and l_f; CPU seconds,
best of ``--repeats`` alternating calls after an untimed warm-up; both must agree bit for bit.

Also the kernel's start-up in fresh processes with an empty numba cache (the compile) and with
that cache filled (the cached load): numba's import, the first call and a second call.

``--cells case:channel_set:runs ...``: each cell of the detection table
(:func:`uqdrive.studies.discrepancy.channel_detection_cell` on one case) with the NumPy pass and
with the kernel, in CPU seconds; its rows and verdict (clock readings left out) must be equal.

    python benchmarks/bench_ltv.py [--realisations 300 1000 2400] [--repeats 3] [--json docs/measurements/benchmarks_ltv.json]
    python benchmarks/bench_ltv.py --cells actuator_lag_200ms:imu_speed:20 actuator_lag_200ms:imu_speed:100 [--json ...]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from timing import without
from uqdrive.config import load_config
from uqdrive.numerics.integrate import rk4_fixed_step_into
from uqdrive.settings import Settings
from uqdrive.vehicle.effects import ModelStructure
from uqdrive.vehicle.single_track import VehicleParameters
from uqdrive.vehicle.track_rk4 import LinearTrackRHS, speed_on_half_steps

H, DURATION = 0.005, 10.0

#: Run in a fresh process: numba's import, the first call (compile or cached load) and a second call, in s.
STARTUP = """
import json, time
import numpy as np
t0 = time.perf_counter()
import numba  # noqa: F401
t1 = time.perf_counter()
from uqdrive.vehicle.dynamics.ltv_rk4 import rk4_linear_track
o, J = np.ones(8), 201
call = lambda: rk4_linear_track(0.01, 100, 1, heading=False, exact=False, P=-o, a12=o, a13=o, W1=o, Q=o, R=-o, S=o, inv_m=o, M_term=None,
                                a_lat=0.0, k=0.0, delta_half=np.zeros(J), F_w_half=np.ones((J, 8)), inv_v=np.full(J, 0.05), rate=np.zeros(J))
t2 = time.perf_counter()
call()
t3 = time.perf_counter()
call()
t4 = time.perf_counter()
print(json.dumps({"numba_import_s": t1 - t0, "first_call_s": t3 - t2, "second_call_s": t4 - t3}))
"""


def braking_rhs(settings, n: int, seed: int = 0) -> LinearTrackRHS:
    """LinearTrackRHS of n realisations braking 70 -> 45 km/h, slalom steering, random gusts."""
    rng = np.random.default_rng(seed)
    n_steps = int(round(DURATION / H))
    t = np.linspace(0.0, DURATION, 1001)
    t_half = np.arange(2 * n_steps + 1) * (H / 2)
    v, v_dot = speed_on_half_steps(t, (70.0 - 25.0 * np.clip((t - 3.0) / 3.0, 0.0, 1.0)) / 3.6, t_half)
    p = VehicleParameters.from_settings(settings, mu=rng.uniform(0.5, 1.1, n), m_load=rng.uniform(0.0, 400.0, n), l_f=rng.uniform(1.1, 1.8, n))
    F_w_half = 300.0 + 400.0 * rng.normal(size=(t_half.size, n))
    return LinearTrackRHS(p, ModelStructure(), 0.03 * np.sin(2.1 * t_half), F_w_half, True, np.full(n, 300.0), v, v_dot, heading=False)


def old(rhs, n_steps):
    return rk4_fixed_step_into(rhs, np.zeros((rhs.n_states, rhs.F_w_half.shape[1])), H, n_steps, 2)


def new(rhs, n_steps):
    from uqdrive.vehicle.dynamics.ltv_rk4 import rk4_linear_track

    return rk4_linear_track(H, n_steps, 2, heading=rhs.heading, exact=rhs.exact, P=rhs.P, a12=rhs.a12, a13=rhs.a13, W1=rhs.W1, Q=rhs.Q,
                            R=rhs.R, S=rhs.S, inv_m=rhs.inv_m, M_term=rhs.M_term, a_lat=rhs.a_lat, k=rhs.k, delta_half=rhs.delta_half,
                            F_w_half=rhs.F_w_half, inv_v=rhs.inv_v, rate=rhs.rate)


def cpu(fn):
    clock = time.process_time()
    out = fn()
    return time.process_time() - clock, out


def startup() -> dict:
    """The kernel's start-up in fresh processes: compiled into an empty cache, then loaded from it."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(Path(__file__).resolve().parents[1] / "src"), os.environ.get("PYTHONPATH", "")])}
    with tempfile.TemporaryDirectory() as cache:
        env["NUMBA_CACHE_DIR"] = cache
        runs = [json.loads(subprocess.run([sys.executable, "-c", STARTUP], env=env, check=True, capture_output=True, text=True).stdout)
                for _ in range(2)]
    return {"numba_import_s": round(runs[0]["numba_import_s"], 2), "compile_s": round(runs[0]["first_call_s"] - runs[0]["second_call_s"], 2),
            "cached_load_s": round(runs[1]["first_call_s"] - runs[1]["second_call_s"], 3)}


def numpy_pass(rhs, h, n_steps, record_every):
    """The simulators' integration along a speed profile by the NumPy reference (states (4, n, K + 1), psi and y NaN without heading)."""
    x = rk4_fixed_step_into(rhs, np.zeros((rhs.n_states, rhs.F_w_half.shape[1])), h, n_steps, record_every)
    if x.shape[1] == 2:
        full = np.full((x.shape[0], 4, x.shape[2]), np.nan)
        full[:, 1:3] = x
        x = full
    return x.transpose(1, 2, 0)


def cells(specs) -> list[dict]:
    """CPU seconds of each detection-table cell with the NumPy pass (before) and the kernel (after), rows and verdicts compared."""
    import uqdrive.vehicle.dynamics.engine as engine
    from uqdrive.inference.discrepancy import DiscrepancyFinder
    from uqdrive.studies.discrepancy import channel_detection_cell
    from uqdrive.studies.hidden_effects import benchmark_cases

    config = load_config(Path(__file__).resolve().parents[1] / "config" / "config.yaml")  # the workflow's, as make reproduce runs the table
    compiled, fit = engine.integrate_linear_ltv, DiscrepancyFinder.fit
    verdicts = []

    def capture(self, data):
        result = fit(self, data)
        verdicts.append(self.verdict_)
        return result

    rows = []
    DiscrepancyFinder.fit = capture
    try:
        for spec in specs:
            name, channel_set, runs = spec.split(":")
            case = {c.name: c for c in benchmark_cases(config)}[name]
            got = {}
            for variant, integrate in (("before", numpy_pass), ("after", compiled)):
                engine.integrate_linear_ltv = integrate
                verdicts.clear()
                seconds, table = cpu(lambda: channel_detection_cell(config, [case], channel_set, int(runs)))
                got[variant] = (seconds, without(table), without(verdicts))
            same = got["before"][1:] == got["after"][1:]
            rows.append({"data": spec.replace(":", ": "), "verdict": got["after"][1][0]["verdict"], "before": round(got["before"][0], 1),
                         "after": round(got["after"][0], 1), "same": same})
            print(f"{spec}: {got['before'][0]:.1f} -> {got['after'][0]:.1f} CPU s, rows and verdict equal: {same}", flush=True)
    finally:
        engine.integrate_linear_ltv, DiscrepancyFinder.fit = compiled, fit
    return rows


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--realisations", type=int, nargs="+", default=[300, 1000, 2400])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--machine", default="this machine", help="words for the record")
    parser.add_argument("--cells", nargs="+", default=None, help="case:channel_set:runs of detection-table cells, before and after")
    parser.add_argument("--json", type=Path, default=None, help="write the record the benchmarks page renders (the other part kept)")
    args = parser.parse_args(argv)
    record = json.loads(args.json.read_text()) if args.json and args.json.exists() else {}
    if args.cells:
        rows = cells(args.cells)
        if args.json:
            record["cells"] = {"command": "python benchmarks/bench_ltv.py --cells " + " ".join(args.cells), "machine": args.machine,
                               "date": time.strftime("%Y-%m-%d", time.gmtime()), "rows": rows}
            args.json.write_text(json.dumps(record, indent=1) + "\n")
        if not all(r["same"] for r in rows):
            raise SystemExit("a cell's rows or verdict differ between the NumPy pass and the kernel")
        return
    settings = Settings.from_config(load_config(None))
    n_steps = int(round(DURATION / H))
    start = startup()
    print(f"numba import {start['numba_import_s']} s, compile {start['compile_s']} s, cached load {start['cached_load_s']} s (fresh processes)")
    print(f"{DURATION:g} s braking 70 -> 45 km/h, RK4 at {H * 1e3:g} ms ({n_steps} steps), psi_dot and beta; CPU s, best of {args.repeats}")
    print("| realisations | NumPy (old) | kernel (new) | old / new | bit for bit |\n|---|---|---|---|---|")
    rows = []
    for n in args.realisations:
        rhs = braking_rhs(settings, n)
        new(rhs, n_steps)  # warm-up: the compile or the cached load
        best = {}
        for _ in range(args.repeats):
            for name, fn in (("old", old), ("new", new)):
                seconds, out = cpu(lambda: fn(rhs, n_steps))
                if name not in best or seconds < best[name][0]:
                    best[name] = (seconds, out)
        same = bool(np.array_equal(best["old"][1], best["new"][1]))
        rows.append({"realisations": n, "old_s": round(best["old"][0], 4), "new_s": round(best["new"][0], 4), "same": same})
        print(f"| {n} | {best['old'][0]:.3f} | {best['new'][0]:.4f} | {best['old'][0] / best['new'][0]:.1f}x | {same} |", flush=True)
    if args.json:
        record.update({"command": "python benchmarks/bench_ltv.py" + (f" --repeats {args.repeats}" if args.repeats != 3 else ""),
                       "machine": args.machine, "date": time.strftime("%Y-%m-%d", time.gmtime()), "duration_s": DURATION, "step_ms": H * 1e3,
                       "steps": n_steps, **start, "rows": rows})
        args.json.write_text(json.dumps(record, indent=1) + "\n")
        print(f"wrote {args.json}")
    if not all(r["same"] for r in rows):
        raise SystemExit("the kernel's states differ from the NumPy pass")


if __name__ == "__main__":
    main()

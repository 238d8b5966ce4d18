"""Benchmark: the JAX chassis programs of discover's passes, compiled for this machine's default JAX
device: fused kernels per RK4 step (XLA's fusions in the compiled step's loop body, each a kernel
launch on a GPU), compile time and the time of one pass, for a program of the pass's own terms and
for the shared program that holds every load and compliance term (``share_programs``), with the
NLST program's kernels per step beside them (its H200 times are in docs/measurements/gpu.json).

    PYTHONPATH=src python3 benchmarks/bench_chassis_programs.py [--realisations 4096] [--steps 600]
        [--repeats 3] [--json FILE]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import re
import time
from pathlib import Path

import numpy as np
from bench_gpu import REPO, _inputs, _settings
from timing import best_of
from uqdrive.numerics.backend import float64
from uqdrive.vehicle import track_extended
from uqdrive.vehicle.accelerated import chassis_ensemble
from uqdrive.vehicle.accelerated.nlst import nlst_program
from uqdrive.vehicle.effects import ModelStructure, effect
from uqdrive.vehicle.single_track import VehicleParameters

#: Effect values of the passes (those of the chassis tests, tests/test_fused_chassis.py).
VALUES = {"lateral_load_transfer": [0.6, -0.4], "longitudinal_load_transfer": [0.55], "combined_slip": [0.8, 0.4],
          "tyre_relaxation": [0.4], "roll_steer": [0.5, 1.7, 0.4], "compliance_steer": [0.4]}
LOADS = ("lateral_load_transfer", "longitudinal_load_transfer", "combined_slip")
#: Passes of a discover's search: (label, chassis terms, linear tyre).
PASSES = [("no chassis term, Magic Formula", (), False), ("no chassis term, linear tyre", (), True),
          ("relaxation and roll steer", ("tyre_relaxation", "roll_steer"), False),
          ("lateral load transfer", ("lateral_load_transfer",), False),
          ("load transfer and combined slip", LOADS, False),
          ("compliance steer, linear tyre", ("compliance_steer",), True)]
V, H, T_W = 70.0 / 3.6, 0.55, 1.6  # m/s, cg height and track width (m)


def _rhs(settings, terms, linear: bool, n: int, n_steps: int):
    """A braking pass's chassis right-hand side of n realisations (seeded draws) on 2 n_steps + 1 half steps."""
    s = ModelStructure() if linear else effect("tyre_saturation").augment(ModelStructure(), [0.97])
    for name in terms:
        s = effect(name).augment(s, VALUES[name])
    rng, J = np.random.default_rng(7), 2 * n_steps + 1
    p = VehicleParameters.from_settings(settings, mu=rng.uniform(0.6, 1.0, n), l_f=rng.uniform(1.4, 1.7, n),
                                        m_load=rng.normal(100, 30, n), v_c=V)
    delta = np.deg2rad(5.0) * np.sin(np.linspace(0.0, 3.0, J))
    return track_extended.ExtendedSingleTrackRHS(p, s, 0.97, delta, None, True, rng.normal(0.0, 2.0, n), H, T_W,
                                                 speed_half=(np.linspace(V, V - 4.0, J), np.full(J, -3.0)), tyre_load_height=H)


def kernels_per_step(hlo: str, steps_per_body: int = 1) -> float:
    """Fusions called in the compiled program's innermost loop body (one that runs no loop), per RK4 step it takes."""
    bodies, current = {}, None
    for line in hlo.splitlines():
        m = re.match(r"^(?:ENTRY )?%?([\w.\-]+) .*\{$", line)
        if m and not line.startswith(" "):
            current = bodies.setdefault(m.group(1), [])
        elif current is not None:
            current.append(line)
    loops = re.findall(r"while\(.*?\), condition=%?[\w.\-]+, body=%?([\w.\-]+)", hlo)
    inner = [body for body in loops if not any(" while(" in line for line in bodies.get(body, []))]
    return max(sum(" fusion(" in line for line in bodies.get(body, [])) for body in inner) / steps_per_body


def _pass(settings, terms, linear: bool, n: int, n_steps: int, share: bool, repeats: int) -> dict:
    rhs = _rhs(settings, terms, linear, n, n_steps)
    rng = np.random.default_rng(11)
    wind, coeffs = rng.uniform(-200.0, 200.0, n), rng.normal(0.0, 150.0, (n, 3))
    modes = np.stack([np.sin((i + 1) * np.linspace(0.0, 3.0, 2 * n_steps + 1)) for i in range(3)])
    captured, original = {}, chassis_ensemble._compiled
    compiled = original()

    def spy(*args, **kwargs):  # keeps the arguments, to read the compiled program's text
        captured.update(args=args, kwargs=kwargs)
        return compiled(*args, **kwargs)

    chassis_ensemble._compiled = lambda: spy
    try:
        run = lambda: chassis_ensemble.integrate_chassis_jax(rhs, 0.01, n_steps, 1, wind, coeffs, modes,  # noqa: E731
                                                             lateral_acceleration=True, share_programs=share)
        t0 = time.perf_counter()
        first = run()
        first_s = time.perf_counter() - t0
        pass_s, _ = best_of(run, repeats)
    finally:
        chassis_ensemble._compiled = original
    with float64():
        hlo = compiled.lower(*captured["args"], **captured["kwargs"]).compile().as_text()
    return {"kernels_per_step": kernels_per_step(hlo), "first_call_s": round(first_s, 3), "pass_s": round(pass_s, 4),
            "states": first[0]}


def _nlst_kernels(settings) -> float:
    """Kernels per RK4 step of the NLST program of the default config (two steps per output interval, unrolled)."""
    with float64():
        function, device_args = nlst_program(*_inputs(settings, 64))
        hlo = function.lower(*device_args).compile().as_text()
    return kernels_per_step(hlo, round(settings.time.dt / settings.time.step))


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--realisations", type=int, default=4096, help="realisations of a pass (default 4096)")
    ap.add_argument("--steps", type=int, default=600, help="RK4 steps of a pass (default 600: 6 s at 0.01 s)")
    ap.add_argument("--repeats", type=int, default=3, help="timed passes, the best kept (default 3)")
    ap.add_argument("--json", type=Path, default=None, help="write the record here")
    args = ap.parse_args(argv)
    import jax

    settings = _settings(REPO / "config" / "config.yaml")
    rows = []
    for label, terms, linear in PASSES:
        own = _pass(settings, terms, linear, args.realisations, args.steps, False, args.repeats)
        shared = _pass(settings, terms, linear, args.realisations, args.steps, True, args.repeats)
        difference = float(np.max(np.abs(own.pop("states") - shared.pop("states"))))
        rows.append({"pass": label, "own": own, "shared": shared, "max_difference": difference})
        print(f"{label:34s} kernels/step own {own['kernels_per_step']:5.1f}, shared {shared['kernels_per_step']:5.1f}; "
              f"pass own {own['pass_s']:.3f} s, shared {shared['pass_s']:.3f} s; max |difference| {difference:.1e}")
    nlst = _nlst_kernels(settings)
    print(f"NLST program (for scale): {nlst:.1f} kernels/step")
    record = {"command": "python benchmarks/bench_chassis_programs.py", "device": str(jax.devices()[0]), "jax": jax.__version__,
              "machine": f"{platform.machine()}, {os.cpu_count()} cores", "realisations": args.realisations, "steps": args.steps,
              "repeats": args.repeats, "nlst_kernels_per_step": nlst, "rows": rows}
    if args.json:
        args.json.write_text(json.dumps(record, indent=1) + "\n")


if __name__ == "__main__":
    main()

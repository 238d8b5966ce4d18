"""Benchmark: the single-track Magic-Formula right-hand side with its arithmetic compiled
(uqdrive.vehicle.dynamics.fused_rates) against the NumPy operations (the baseline, in the same run).

1. One right-hand-side call at discover's batch sizes (300 realisations: a fit's model; 2400: a
   Jacobian's pairs of six parameters and an effect), best of ``--repeats`` x 2000 calls.
2. ``discover`` as the README's tour runs it (200 NLST runs of the packaged config, every
   candidate, the posterior), CPU seconds of each variant (the NumPy one first, after an untimed
   warm-up that compiles the loops), and whether the two verdicts are equal number for number
   (their clock readings aside).

    python benchmarks/bench_fused_rates.py [--repeats 3] [--no-discover] [--json FILE] [--machine TEXT]
"""

from __future__ import annotations

import argparse

import numpy as np

from timing import discover_cpu, per_call, record_arguments, report_compiled, without
from uqdrive.config import load_config
from uqdrive.settings import Settings
from uqdrive.vehicle.dynamics import rhs as rhs_module
from uqdrive.vehicle.single_track import VehicleParameters


def _rhs(n: int, fused: bool):
    rng = np.random.default_rng(0)
    p = VehicleParameters.from_settings(Settings.from_config(load_config(None)), mu=rng.normal(1.0, 0.2, n),
                                        l_f=rng.normal(1.55, 0.2, n), m_load=rng.normal(100.0, 30.0, n))
    J = 50
    inputs = rhs_module.HalfStepInputs(np.deg2rad(5.0) * np.sin(np.linspace(0.0, 3.0, J)), rng.normal(0.0, 100.0, (J, n)))
    rhs_module.FUSED = fused
    try:
        return rhs_module.SingleTrackRHS(p, inputs), rng.normal(0.0, 0.05, (4, n))
    finally:
        rhs_module.FUSED = True


def _calls(n: int, fused: bool, repeats: int, calls: int = 2000):
    return per_call(*_rhs(n, fused), repeats, calls)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--no-discover", action="store_true")
    record_arguments(ap)
    args = ap.parse_args(argv)
    rows = []
    for n in (300, 2400):
        (old, a), (new, b) = _calls(n, False, args.repeats), _calls(n, True, args.repeats)
        rows.append({"case": f"rhs call, {n} realisations", "numpy_s": old, "compiled_s": new, "ratio": old / new,
                     "same": bool(np.array_equal(a, b))})
    if not args.no_discover:
        import uqdrive

        runs = uqdrive.simulate("nlst", samples=200)
        discover_cpu(rhs_module, True, runs)  # warm-up: imports, numba's cache
        (old, va), (new, vb) = discover_cpu(rhs_module, False, runs), discover_cpu(rhs_module, True, runs)
        rows.append({"case": "discover, README tour (CPU s)", "numpy_s": old, "compiled_s": new, "ratio": old / new,
                     "same": without(va) == without(vb)})
    report_compiled(rows, args, "python benchmarks/bench_fused_rates.py", 34)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

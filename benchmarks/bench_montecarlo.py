"""Benchmark: one 2000-run ensemble (vectorised) against per-realisation solve_ivp (ode45's
method and default tolerances), timed on a subset and scaled; both errors against DOP853 at
rtol 1e-10. Also the peak memory of the synthesis. Run: `make bench` (prints a table).
"""

from __future__ import annotations

import argparse
import resource
import time
import tracemalloc
from pathlib import Path

import numpy as np

from uqdrive.config import load_config
from uqdrive.vehicle.montecarlo import simulate_ensemble, wind_kle
from uqdrive.vehicle.reference import solve_realisations
from uqdrive.vehicle.single_track import STATES
from uqdrive.settings import Settings

REPO = Path(__file__).resolve().parents[1]


def _max_rel_error(x, ref):
    return float((np.abs(x - ref).max(axis=(0, 1)) / np.abs(ref).max(axis=(0, 1))).max())


def bench(model: str, config, kle, subset: int, targets: dict) -> dict:
    n = config["montecarlo"]["samples"]
    times = []
    for _ in range(3):  # best of three, as timeit does: the first run also pays for page faults
        t0 = time.perf_counter()
        ds = simulate_ensemble(Settings.from_config(config), model, kle=kle)
        times.append(time.perf_counter() - t0)
    t_ours = min(times)
    idx = np.linspace(0, n - 1, subset).astype(int)
    t0 = time.perf_counter()
    baseline = solve_realisations(Settings.from_config(config), ds, kle, idx)  # RK45, rtol 1e-3, atol 1e-6
    t_base = (time.perf_counter() - t0) * n / subset
    ref = solve_realisations(Settings.from_config(config), ds, kle, idx, "DOP853", 1e-10, 1e-12)
    ours = np.stack([ds[s].values[idx] for s in STATES], axis=-1)
    return {
        "model": model.upper(),
        "ours_s": t_ours,
        "baseline_s": t_base,
        "speedup": t_base / t_ours,
        "target": targets[model],
        "err_ours": _max_rel_error(ours, ref),
        "err_baseline": _max_rel_error(baseline, ref),
    }


def peak_memory(config, kle) -> float:
    """Peak traced Python/NumPy allocation (MiB) of one NLST ensemble synthesis."""
    tracemalloc.start()
    simulate_ensemble(Settings.from_config(config), "nlst", kle=kle)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    return peak / 2**20


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--config", default=REPO / "config" / "config.yaml")
    parser.add_argument("--subset", type=int, default=20, help="realisations timed with solve_ivp")
    args = parser.parse_args()
    config = load_config(args.config)
    kle = wind_kle(Settings.from_config(config))
    rows = [bench(m, config, kle, args.subset, {"lst": 1000, "nlst": 50}) for m in ("lst", "nlst")]
    n = config["montecarlo"]["samples"]
    print(f"{n}-run ensembles, 0-{config['time']['t_end']} s, step {config['time']['step']} s; baseline = solve_ivp RK45 "
          f"(rtol 1e-3, atol 1e-6) per realisation, {args.subset} timed and scaled; errors = max relative vs DOP853 rtol 1e-10")
    print(f"{'model':6} {'uqdrive [s]':>12} {'solve_ivp [s]':>14} {'speed-up':>9} {'target':>7} {'err uqdrive':>12} {'err solve_ivp':>14}")
    for r in rows:
        print(f"{r['model']:6} {r['ours_s']:12.3f} {r['baseline_s']:14.1f} {r['speedup']:8.0f}x {r['target']:6d}x {r['err_ours']:12.2e} {r['err_baseline']:14.2e}")
    peak = peak_memory(config, kle)
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"peak traced memory of the NLST synthesis: {peak:.0f} MiB (target < 2048 MiB); process max RSS {rss:.0f} MiB")


if __name__ == "__main__":
    main()

"""Benchmark: the emcee cross-check's log-posterior, one scalar PCE evaluation per walker (as
before, `log_posterior`) against one batched evaluation per half-ensemble update of all
ensembles in lockstep (`log_posteriors`, `LSTChaosModel.moments_batch`), on the default config
(sampler model on bayes.model_dt with the KLE gusts). Prints per-evaluation times and a short
sampling run of bayes.ensembles ensembles both ways (same seed: the chains must be identical),
with the ratios old/new from the same run. Run: `python benchmarks/bench_posterior.py`.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from timing import best_of

from uqdrive.config import load_config
from uqdrive.inference.bayes import log_posterior, log_posteriors, sample_ensembles
from uqdrive.numerics.threads import single_blas_thread
from uqdrive.studies.bayes import _models, _setup_case, prepare_data
from uqdrive.vehicle.montecarlo import simulate_ensemble
from uqdrive.settings import Settings

REPO = Path(__file__).resolve().parents[1]


def cpu_best_of(fn, repeats: int):
    """Smallest CPU time of ``repeats`` calls (s): on a shared machine the process's own CPU
    time is less disturbed by the other processes than the wall time."""
    times = []
    for _ in range(repeats):
        t0 = time.process_time()
        fn()
        times.append(time.process_time() - t0)
    return min(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--config", default=REPO / "config" / "config.yaml")
    parser.add_argument("--steps", type=int, default=100, help="sampling steps after the burn-in (rounded up to check_every)")
    parser.add_argument("--burn-in", type=int, default=50)
    parser.add_argument("--repeats", type=int, default=20)
    args = parser.parse_args()
    config = load_config(args.config)
    b = config["bayes"]
    x, _ = prepare_data(config, simulate_ensemble(Settings.from_config(config), "lst"))
    models = _models(config)
    case = _setup_case(config, x, None, np.random.default_rng(0), None, models)
    like, prior, index = case["target"]
    every, coarse = case["every"], models[1]
    model_index = index * every
    rng = np.random.default_rng(1)
    centre = case["starts"][0]
    walkers, n_ens = b["walkers"], len(case["starts"])
    half = walkers // 2

    # --- one evaluation ---------------------------------------------------------------------------
    thetas = centre * (1.0 + 0.01 * rng.standard_normal((n_ens * half, centre.size)))
    old = np.array([log_posterior(t, coarse, like, prior, model_index) for t in thetas])
    new = log_posteriors(coarse, [(thetas, like, prior, index)], every)[0]
    assert np.allclose(new, old, rtol=1e-9), "batched and scalar log-posteriors differ"
    print(f"sampler model: {coarse.expanded_states.size} expanded states, {coarse.time.size} times (the likelihood reads 1 in {every}), "
          f"{index.size} likelihood times")
    with single_blas_thread():
        t_old_wall, _ = best_of(lambda: [log_posterior(t, coarse, like, prior, model_index) for t in thetas[:half]], args.repeats)
        t_old = cpu_best_of(lambda: [log_posterior(t, coarse, like, prior, model_index) for t in thetas[:half]], args.repeats) / half
        rows = []
        for n in (1, half, n_ens * half):
            t_wall, _ = best_of(lambda: log_posteriors(coarse, [(thetas[:n], like, prior, index)], every), args.repeats)
            t_cpu = cpu_best_of(lambda: log_posteriors(coarse, [(thetas[:n], like, prior, index)], every), args.repeats)
            rows.append((n, t_wall, t_cpu))
    print(f"{'log-posterior':46} {'per theta, CPU [ms]':>20} {'call, wall [ms]':>16} {'old/new':>8}")
    print(f"{'old: scalar log_posterior (one PCE call each)':46} {1e3 * t_old:20.3f} {1e3 * t_old_wall / half:16.3f} {1.0:8.1f}")
    for n, t_wall, t_cpu in rows:
        label = {1: "new: batched, 1 theta", half: f"new: batched, {n} thetas (half-ensemble)"}.get(n, f"new: batched, {n} thetas (lockstep)")
        print(f"{label:46} {1e3 * t_cpu / n:20.3f} {1e3 * t_wall:16.3f} {t_old * n / t_cpu:8.1f}")

    # --- a short sampling run ------------------------------------------------------------------------
    kw = {"walkers": walkers, "max_steps": args.steps, "check_every": min(b["check_every"], args.steps), "tau_factor": b["tau_factor"],
          "burn_in": args.burn_in, "moves": b["moves"]}
    runs = {}
    for name in ("old", "new"):
        t0, c0 = time.perf_counter(), time.process_time()
        if name == "old":
            runs[name] = sample_ensembles(lambda t: log_posterior(t, coarse, like, prior, model_index), case["starts"], rng=np.random.default_rng(2), **kw)
        else:
            runs[name] = sample_ensembles(lambda calls: log_posteriors(coarse, [(t, like, prior, index) for _, t in calls], every),
                                          case["starts"], rng=np.random.default_rng(2), lockstep=True, **kw)
        runs[name + "_time"] = (time.perf_counter() - t0, time.process_time() - c0)
    same = all(np.array_equal(a["chain"], c["chain"]) for a, c in zip(runs["old"], runs["new"]))
    steps = sum(r["chain"].shape[0] + args.burn_in for r in runs["new"])
    (w_old, c_old), (w_new, c_new) = runs["old_time"], runs["new_time"]
    print(f"sampling {n_ens} ensembles x {walkers} walkers, {steps} steps in all ({steps * walkers} evaluations), identical chains: {same}")
    print(f"  old (sequential, scalar): {w_old:7.1f} s wall, {c_old:7.1f} s CPU")
    print(f"  new (lockstep, batched):  {w_new:7.1f} s wall, {c_new:7.1f} s CPU   old/new: {w_old / w_new:.1f}x wall, {c_old / c_new:.1f}x CPU")


if __name__ == "__main__":
    main()

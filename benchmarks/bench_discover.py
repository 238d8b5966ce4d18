"""One `discover` run on 1000 samples (the thesis' case: NLST data against the LST) against the
issue's budget of 3 minutes on 2 cores; prints the time of each stage and the ratio to budget, and
the emcee posterior's share when the config samples it (discrepancy.posterior)."""

import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from uqdrive.config import load_config
from uqdrive.io import write_dataset
from uqdrive.studies.hidden_effects import benchmark_cases, generate

BUDGET = 180.0


def main():
    config = load_config(None)
    case = {c.name: c for c in benchmark_cases(config, samples=1000)}["thesis_nlst"]
    with tempfile.TemporaryDirectory() as tmp:
        measured = Path(tmp) / "measured.nc"
        write_dataset(generate(config, case), measured)
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-m", "uqdrive.cli.main", "discover", str(measured), "--out", str(Path(tmp) / "out")], check=True)
        wall = time.perf_counter() - t0
        verdict = json.loads((Path(tmp) / "out" / "verdict.json").read_text())
    stages = verdict["evidence"]["stage_seconds"]
    post = verdict.get("posterior")
    print(f"discover, 1000 samples, thesis case: {wall:.1f} s wall (budget {BUDGET:.0f} s, ratio {wall / BUDGET:.2f}); "
          f"effect {verdict['effect']}, stages {stages}")
    if post:  # the optional emcee posterior (config discrepancy.posterior) is part of the wall time above
        print(f"  of which the emcee posterior: {stages.get('posterior', float('nan')):.1f} s (without it {wall - stages.get('posterior', 0.0):.1f} s); "
              f"mu mean {post['mu_mean'][0]:.4f} [{post['mu_mean'][1]:.4f}, {post['mu_mean'][2]:.4f}], "
              f"R-hat max {max(post['r_hat'].values()):.3f}, tau max {max(post['tau'].values()):.0f}, "
              f"{post['model_evaluations']} model evaluations, surrogate validated {post['surrogate']['passed']}")


if __name__ == "__main__":
    main()

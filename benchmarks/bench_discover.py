"""`discover` runs on 1000 samples against the budget of 3 minutes on 2 cores: the thesis' case
(NLST data against the LST) and a case with three hidden effects at once (course angle, road
bank, actuator lag; `--case combined_course_bank_lag`); prints the time of each stage and the
ratio to budget, and the emcee posterior's share when the config samples it (discrepancy.posterior)."""

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


def main(argv=None):
    import argparse

    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--case", default="thesis_nlst", help="benchmark case (uqdrive.studies.hidden_effects.benchmark_cases)")
    args = parser.parse_args(argv)
    config = load_config(None)
    case = {c.name: c for c in benchmark_cases(config, samples=1000)}[args.case]
    with tempfile.TemporaryDirectory() as tmp:
        measured = Path(tmp) / "measured.nc"
        write_dataset(generate(config, case), measured)
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-m", "uqdrive.cli.main", "discover", str(measured), "--out", str(Path(tmp) / "out")], check=True)
        wall = time.perf_counter() - t0
        verdict = json.loads((Path(tmp) / "out" / "verdict.json").read_text())
    stages = verdict["evidence"]["stage_seconds"]
    post = verdict.get("posterior")
    named = [e["effect"] for e in verdict["effects"]] or [verdict["effect"]]
    print(f"discover, 1000 samples, {args.case}: {wall:.1f} s wall (budget {BUDGET:.0f} s, ratio {wall / BUDGET:.2f}); "
          f"effects {named}, stages {stages}")
    if post:  # the optional emcee posterior (config discrepancy.posterior) is part of the wall time above
        print(f"  of which the emcee posterior: {stages.get('posterior', float('nan')):.1f} s (without it {wall - stages.get('posterior', 0.0):.1f} s); "
              f"mu mean {post['mu_mean'][0]:.4f} [{post['mu_mean'][1]:.4f}, {post['mu_mean'][2]:.4f}], "
              f"R-hat max {max(post['r_hat'].values()):.3f}, tau max {max(post['tau'].values()):.0f}, "
              f"{post['model_evaluations']} model evaluations, surrogate validated {post['surrogate']['passed']}")


if __name__ == "__main__":
    main()

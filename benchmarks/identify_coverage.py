"""Calibration of `uqdrive identify`'s error bars and misfit test over seeded replicate data sets
(uqdrive.studies.identification.coverage_study): per parameter the share of 95 % intervals that
cover the truth, with the 99 % binomial band of the replicate count, the spread of the estimates
over the mean standard error, and the misfit test's pass rate. Prints a Markdown table
(docs/identification.md carries its numbers).

    python benchmarks/identify_coverage.py [REPLICATES] [DT] [SAMPLES ...]
"""

import sys
import time

from uqdrive.config import load_config
from uqdrive.studies.identification import coverage_study, coverage_table


def main(replicates: int = 200, dt: float = 0.05, samples=(300, 1000)):
    config = load_config(None)
    print(f"{replicates} replicates on a {dt} s grid")
    print("| runs | parameter | coverage 95 % | 99 % band | spread / SE |")
    print("|---|---|---|---|---|")
    for n in samples:
        t0 = time.perf_counter()
        table = coverage_table(coverage_study(config, replicates, n, dt=dt))
        for row in table.itertuples():
            spread = "" if row.spread_over_se != row.spread_over_se else f"{row.spread_over_se:.3f}"
            print(f"| {n} | {row.parameter} | {row.coverage_95:.3f} | [{row.band_lo:.3f}, {row.band_hi:.3f}] | {spread} |")
        print(f"<!-- {replicates} replicates x {n} runs: {time.perf_counter() - t0:.0f} s -->")


if __name__ == "__main__":
    args = sys.argv[1:]
    main(int(args[0]) if args else 200, float(args[1]) if len(args) > 1 else 0.05, tuple(int(a) for a in args[2:]) or (300, 1000))

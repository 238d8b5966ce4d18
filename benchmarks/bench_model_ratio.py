"""Detection-table cells at `discrepancy.model_ratio` 0 (every discover at model_samples) against
the workflow's ratio, in one process.

The cells run as the workflow runs them (config/config.yaml, `studies.discrepancy.channel_detection_cell`),
the two ratios alternating, 0 first, after an untimed warm-up cell (imports, caches). Per cell:
CPU-seconds of each, the realisations M used, whether the cell's rows are equal and whether the
whole verdicts are (less their clock readings and the two provenance keys, model_samples and
model_ratio); a cell whose runs times the ratio reach model_samples must be equal number for number.

Usage: python benchmarks/bench_model_ratio.py [--cells cell:actuator_lag_200ms:imu_speed:20 ...] [--json FILE]
"""

import argparse
import copy
import json
import os
import platform
import time
from pathlib import Path

import uqdrive.inference.discrepancy as discrepancy
from timing import without
from uqdrive.config import load_config
from uqdrive.studies.discrepancy import channel_detection_cell
from uqdrive.studies.hidden_effects import benchmark_cases

CONFIG = Path(__file__).resolve().parents[1] / "config" / "config.yaml"
DEFAULT_CELLS = ("cell:none_step:imu:20", "cell:actuator_lag_200ms:imu_speed:20", "cell:tyre_saturation_5deg:all:40", "cell:none_step:imu:100")
PROVENANCE = ("seconds", "stage_seconds", "model_samples", "model_ratio")


def _strip(v):
    """An output without its clock readings and the realisations' provenance."""
    return without(v, PROVENANCE)


class _Keeping(discrepancy.DiscrepancyFinder):
    """The finder the cell builds, keeping each verdict it writes."""

    verdicts: list = []

    def fit(self, ds):
        super().fit(ds)
        self.verdicts.append(self.verdict_)
        return self


def run_cell(config, ratio: float, cell: str):
    """CPU-seconds, rows and the verdict of one cell ``cell:CASE:SET:RUNS`` at ``ratio``."""
    _, name, channel_set, runs = cell.split(":")
    c = copy.deepcopy(config)
    c["discrepancy"]["model_ratio"] = ratio
    case = {x.name: x for x in benchmark_cases(c)}[name]
    _Keeping.verdicts.clear()
    clock = time.process_time()
    rows = channel_detection_cell(c, [case], channel_set, int(runs))
    return time.process_time() - clock, rows, _Keeping.verdicts[0]


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--cells", nargs="+", default=list(DEFAULT_CELLS), help="cell:CASE:SET:RUNS")
    parser.add_argument("--json", type=Path, help="write the record here")
    args = parser.parse_args(argv)
    config = load_config(CONFIG)
    ratio = config["discrepancy"]["model_ratio"]
    discrepancy.DiscrepancyFinder = _Keeping  # channel_detection_cell imports the finder from the package when it runs
    run_cell(config, ratio, "cell:none_step:imu:20")  # untimed warm-up
    rows = []
    for cell in args.cells:
        old, rows_old, v_old = run_cell(config, 0, cell)
        new, rows_new, v_new = run_cell(config, ratio, cell)
        row = {"cell": cell, "verdict": rows_new[0]["verdict"], "M_ratio_0": v_old["evidence"]["model_samples"],
               f"M_ratio_{ratio:g}": v_new["evidence"]["model_samples"], "cpu_s_ratio_0": round(old, 1), f"cpu_s_ratio_{ratio:g}": round(new, 1),
               "rows_equal": _strip(rows_old) == _strip(rows_new), "verdicts_equal": _strip(v_old) == _strip(v_new)}
        rows.append(row)
        print(f"{cell}: M {row['M_ratio_0']} -> {v_new['evidence']['model_samples']}, {old:.1f} -> {new:.1f} CPU-s ({old / new:.2f}x), "
              f"verdict {row['verdict']}, rows equal: {row['rows_equal']}, verdicts equal: {row['verdicts_equal']}", flush=True)
    record = {"command": "python benchmarks/bench_model_ratio.py", "machine": f"{platform.machine()}, {os.cpu_count()} cores, load "
              f"{os.getloadavg()[0]:.1f} at the end", "rows": rows}
    if args.json:
        args.json.write_text(json.dumps(record, indent=1) + "\n")


if __name__ == "__main__":
    main()

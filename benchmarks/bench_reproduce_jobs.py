"""Representative jobs of the reproduction's two discrepancy rules, old against new in one run:
benchmark discovers (rule discrepancy_discover: combined, saturation, delay and null cases) and
detection-table cells (rule discrepancy_channel_cell), one whose baseline cannot explain the data.

"new": the package as it is: a candidate fit stops once its Gauss-Newton model predicts less
than a share of the null band's chi2 standard deviation at consecutive points, or where even
twice that decrease leaves it above the chi2 it must reach to matter (a hopeless probe of a
non-linear candidate, a refit that cannot remove an effect)
(:func:`uqdrive.inference.discrepancy.ranking.resolved_least_squares`). "old" (``--old``):
``reach``, without the hopeless stop; ``trf``, every candidate fit to trf's tolerances;
``footing``, the non-linear footing's band bootstrapping the data anew instead of reading the
null band's replicates (:meth:`uqdrive.inference.discrepancy.comparison.NullBands.footing`).
``--new-only`` runs the new variant alone and compares it with ``--reference``.
Every moved number is listed with its change in null-band chi2 standard deviations where it is a
chi2 (``chi2_null_sd`` of the job's verdict). The jobs run as the workflow runs them (config/config.yaml; the case's ensemble made by
`studies.hidden_effects.generate`, the cell by `studies.discrepancy.channel_detection_cell`);
the two variants alternate in one process, the new one first, after an untimed warm-up discover
(imports, caches). The outputs must agree in what the verdict says (the named effects, the
ambiguity, the untestable candidates, the decision); the record lists every number that moved
by more than 1e-6 relative, with the old and new value.

Usage: python benchmarks/bench_reproduce_jobs.py [--jobs discover:combined_saturation_lag cell:actuator_lag_200ms:imu_speed:20 ...]
       [--json docs/measurements/benchmarks_reproduce_jobs.json] [--reference RESULTS] [--old reach|trf|footing] [--new-only]
"""

import argparse
import contextlib
import json
import os
import platform
import time
from pathlib import Path
from unittest import mock

from timing import moved, without
from uqdrive.config import load_config
from uqdrive.inference.discrepancy import ranking
from uqdrive.inference.discrepancy.comparison import NullBands
from uqdrive.inference.discrepancy.fitter import CandidateFitter

CONFIG = Path(__file__).resolve().parents[1] / "config" / "config.yaml"
DEFAULT_JOBS = ("cell:actuator_lag_200ms:imu_speed:20", "cell:sensor_scale_psi_dot_125:imu_speed:20", "cell:tyre_saturation_5deg:imu_speed:40",
                "discover:combined_saturation_lag", "discover:tyre_saturation_5deg", "discover:actuator_delay_150ms", "discover:none_step")
#: What a verdict says, as opposed to how well it fits: these must be equal between the variants.
VERDICT_KEYS = ("effect", "verdict", "correct", "untestable", "ambiguous_with", "decision", "named", "significant", "rejected", "removed")


def null_sd(output):
    """The null band's chi2 standard deviation of a discover's verdict (None for a cell's rows)."""
    return output.get("evidence", {}).get("chi2_null_sd") if isinstance(output, dict) else None


def in_null_sd(path: str, old, new, sd):
    """A moved chi2 (a fit's, a candidate's, a screening prediction's) in null-band chi2
    standard deviations; None for any other number."""
    chi2_like = "chi2" in path or ".candidates." in path or ".screening." in path or ".model_fits." in path
    if sd and chi2_like and all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in (old, new)):
        return round((new - old) / sd, 4)
    return None


def reference_output(reference: Path, job: str):
    """A job's output in a reproduction's results folder (``results/`` of ``make reproduce``), or None."""
    kind, name, *cell = job.split(":")
    path = (reference / "discrepancy" / "benchmark" / "discover" / name / "verdict.json" if kind == "discover"
            else reference / "discrepancy" / "channel_sets" / cell[0] / cell[1] / f"{name}.json")
    return without(json.loads(path.read_text())) if path.exists() else None


def says(output) -> dict:
    """What a job's verdict says: the named effects and the keys of :data:`VERDICT_KEYS`."""
    rows = output if isinstance(output, list) else [output]
    out = []
    for r in rows:
        d = {k: r[k] for k in VERDICT_KEYS if k in r}
        if "effects" in r:
            d["effects"] = [e.get("effect") for e in r["effects"]]
        out.append(d)
    return out


def without_hopeless_stop():
    """Within the block, no fit stops for being out of reach (an infinite optimism: never hopeless)."""
    return mock.patch.object(ranking, "HOPELESS_OPTIMISM", float("inf"))


def to_trf_tolerances():
    """Within the block, the candidates' fits run to trf's tolerances (no resolution stop, no hopeless stop)."""
    stack = contextlib.ExitStack()
    stack.enter_context(mock.patch.object(CandidateFitter, "resolve_at", lambda fitter, band: None))
    stack.enter_context(without_hopeless_stop())
    return stack


def footing_bootstraps_its_own_data():
    """Within the block, the non-linear footing's band bootstraps the data anew (on stream 99)
    instead of reading the null band's replicates: the cost of a second bootstrap of the data."""
    footing, replicates = NullBands.footing, NullBands.replicates

    def own(self, base):
        with mock.patch.object(NullBands, "replicates", lambda bands, fit, key=0: replicates(bands, fit, 99)):
            return footing(self, base)

    return mock.patch.object(NullBands, "footing", own)


#: The old variants: (context, description).
OLD = {"reach": (without_hopeless_stop, "candidate fits stopped at the resolution only (no hopeless stop)"),
       "footing": (footing_bootstraps_its_own_data, "the non-linear footing's band bootstraps the data a second time"),
       "trf": (to_trf_tolerances, "every candidate fit to trf's tolerances")}


def run_job(config, job: str):
    """CPU seconds and output of one job, ``discover:CASE`` or ``cell:CASE:SET:RUNS``."""
    from uqdrive.cli.discover import discover_dataset
    from uqdrive.studies.discrepancy import channel_detection_cell
    from uqdrive.studies.hidden_effects import benchmark_cases, generate

    kind, name, *cell = job.split(":")
    if kind == "discover":
        case = {c.name: c for c in benchmark_cases(config, samples=config["discrepancy"]["benchmark"]["samples"])}[name]
        data = generate(config, case)
        clock = time.process_time()
        _, verdict = discover_dataset(config, data, name)
        return time.process_time() - clock, without(verdict)
    case = {c.name: c for c in benchmark_cases(config)}[name]
    clock = time.process_time()
    rows = channel_detection_cell(config, [case], cell[0], int(cell[1]))
    return time.process_time() - clock, without(rows)


def every_job(results: Path) -> list:
    """The discrepancy jobs of a reproduction's results folder: discover:CASE and cell:CASE:SET:RUNS."""
    base = results / "discrepancy"
    jobs = [f"discover:{d.name}" for d in sorted((base / "benchmark" / "discover").iterdir()) if (d / "verdict.json").exists()]
    return jobs + [f"cell:{f.stem}:{f.parent.parent.name}:{f.parent.name}" for f in sorted((base / "channel_sets").glob("*/*/*.json"))]


def compare_folders(results: Path, reference: Path) -> None:
    """Print every job whose verdict (:func:`says`) differs between two reproductions' results."""
    differ = []
    for job in every_job(results):
        new, old = reference_output(results, job), reference_output(reference, job)
        if old is None or says(new) != says(old):
            differ.append(job)
            print(f"{job}: {says(old) if old is not None else 'not in the reference'} -> {says(new)}", flush=True)
    print(f"{len(every_job(results))} jobs compared, {len(differ)} differ")
    if differ:
        raise SystemExit(1)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--jobs", nargs="+", default=list(DEFAULT_JOBS), help="discover:CASE or cell:CASE:SET:RUNS")
    parser.add_argument("--json", type=Path, help="write the record here")
    parser.add_argument("--reference", type=Path, help="a reproduction's results folder: each new verdict compared with its own there")
    parser.add_argument("--old", choices=sorted(OLD), default="reach", help="the old variant (default: reach)")
    parser.add_argument("--new-only", action="store_true", help="only the new variant, compared with --reference")
    parser.add_argument("--compare", type=Path, help="no runs: every job of this results folder compared with --reference's")
    args = parser.parse_args(argv)
    if args.compare:
        return compare_folders(args.compare, args.reference)
    old_context, old_text = OLD[args.old]
    config = load_config(CONFIG)
    run_job(config, "discover:none_step_held")  # untimed: the first discover's imports and caches would fall on the old variant
    rows = []
    for job in args.jobs:
        new, out_new = run_job(config, job)
        if args.new_only:
            old, out_old = new, out_new
        else:
            with old_context():
                old, out_old = run_job(config, job)
        same = says(out_old) == says(out_new)
        changes = moved(out_old, out_new)
        ref = reference_output(args.reference, job) if args.reference else None
        as_reference = None if ref is None else says(ref) == says(out_new)
        rows.append({"job": job, "verdict": says(out_new), "old_cpu_s": round(old, 1), "new_cpu_s": round(new, 1), "same_verdict": same,
                     "same_verdict_as_reference": as_reference,
                     "chi2_null_sd": null_sd(out_old),
                     "moved": [{"at": p, "old": a, "new": b, "null_sd": in_null_sd(p, a, b, null_sd(out_old))} for p, a, b in changes]})
        print(f"{job}: old {old:.1f} CPU-s, new {new:.1f} CPU-s ({old / new:.2f}x), verdict {says(out_new)}, same verdict: {same}, "
              f"{len(changes)} numbers moved, as the reference: {as_reference}", flush=True)
        for p, a, b in changes:
            print(f"    {p}: {a} -> {b} ({in_null_sd(p, a, b, null_sd(out_old))} null sd)", flush=True)
    record = {"command": "python benchmarks/bench_reproduce_jobs.py" + (f" --old {args.old}" if args.old != "reach" else ""), "old": old_text,
              "new": "the package as it is: candidate fits stopped at the resolution and where out of reach "
              "(uqdrive.inference.discrepancy.ranking.resolved_least_squares), the footing's band on the null band's replicates",
              "machine": f"{platform.machine()}, {os.cpu_count()} cores, load "
              f"{os.getloadavg()[0]:.1f} at the end", "rows": rows, "date": time.strftime("%Y-%m-%d")}
    if args.reference:
        record["reference"] = str(args.reference)
    if args.json:
        args.json.write_text(json.dumps(record, indent=1) + "\n")
    if not all(r["same_verdict"] and r["same_verdict_as_reference"] is not False for r in rows):
        raise SystemExit("the new variant's verdicts differ from the old one's or the reference's")


if __name__ == "__main__":
    main()

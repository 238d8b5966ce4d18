"""Out-of-sample false-alarm rate of the whole `discover` procedure on null data.

Each replicate is a fresh null ensemble (no hidden effect) made by the hidden-effect generator
from one of the benchmark's null templates (the six `none` cases and the three held-input ones of
studies/hidden_cases.yaml, taken in turn), with a seed the benchmark never used, and `discover`
runs on it in full (baseline fit, null bootstrap with its own seed, forward selection, backward
check, verdict) with the config's settings and default candidates. A replicate is a false alarm
when the verdict names anything (an effect or `unrecognised`). The procedure's threshold is
calibrated on each replicate's own null bootstrap, so the replicates are out of sample. The rate
is reported with its exact (Clopper-Pearson) 95 % interval and the one-sided 95 % upper bound,
the number to hold against the 5 % target; FILE.scorecard.csv holds it as a scorecard row
(uqdrive.studies.discrepancy.false_alarm_row).

    python benchmarks/bench_false_alarm.py --replicates 120 [--samples 1000] [--out FILE.json] [--first-seed 50000]

Results are written after every replicate (atomically), so an interrupted run keeps what it
measured; `--resume` continues a file. The committed record is docs/measurements/false_alarm.json
(--out) with its scorecard row beside it. The candidate list enters only after the null gate: a
replicate the gate finds not significant is named `none` whatever the candidates are; only a
significant one can be an alarm, and the candidates decide what it names.
"""

from __future__ import annotations

import argparse
import json
import time
from dataclasses import replace
from pathlib import Path

from uqdrive.config import load_config
from uqdrive.inference.discrepancy.finder import DiscrepancyFinder
from uqdrive.settings import Settings
from uqdrive.io import atomic_path
from uqdrive.studies.discrepancy import clopper_pearson, false_alarm_row
from uqdrive.studies.hidden_effects import benchmark_cases, generate
from uqdrive.studies.scorecard import write_scorecard

TARGET = 0.05


def null_templates(config, samples):
    return [c for c in benchmark_cases(config, samples=samples) if c.effect == "none"]


def summarise(rows):
    n = len(rows)
    k = sum(r["alarm"] for r in rows)
    lo, hi, upper = clopper_pearson(k, n) if n else (float("nan"),) * 3
    return {"replicates": n, "alarms": k, "rate": k / n if n else float("nan"), "ci95": [lo, hi], "upper95_one_sided": upper,
            "target": TARGET, "holds": bool(n and upper <= TARGET)}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--replicates", type=int, default=120)
    ap.add_argument("--samples", type=int, default=1000, help="realisations per null ensemble (held templates keep their smaller size)")
    ap.add_argument("--first-seed", type=int, default=50_000, help="seed of the first replicate (the benchmark's cases use root + 101 ...)")
    ap.add_argument("--out", type=Path, default=Path("false_alarm.json"))
    ap.add_argument("--resume", action="store_true")
    args = ap.parse_args(argv)
    config = load_config(Path(__file__).resolve().parents[1] / "config" / "config.yaml")  # the reproduction's candidates
    templates = null_templates(config, args.samples)
    rows = json.loads(args.out.read_text())["runs"] if args.resume and args.out.exists() else []
    for i in range(len(rows), args.replicates):
        template = templates[i % len(templates)]
        seed = args.first_seed + i
        case = replace(template, seed=seed)
        t0 = time.perf_counter()
        ds = generate(config, case)
        finder = DiscrepancyFinder(Settings.from_config(config), seed=seed, posterior=False).fit(ds)
        v = finder.verdict_
        named = [e["effect"] for e in v["effects"]]
        rows.append({"replicate": i, "template": template.name, "seed": seed, "samples": case.samples, "hold": case.hold,
                     "verdict": v["effect"], "named": named, "alarm": v["effect"] != "none",
                     "max_statistic": v["evidence"]["max_statistic"], "threshold": v["evidence"]["threshold"],
                     "gap_before": v["gap_before"], "gap_after": v["gap_after"], "seconds": round(time.perf_counter() - t0, 1)})
        s = summarise(rows)
        with atomic_path(args.out) as tmp:
            Path(tmp).write_text(json.dumps({"summary": s, "config_seed": int(config["seed"]), "first_seed": args.first_seed,
                                             "samples": args.samples, "runs": rows}, indent=1))
        r = rows[-1]
        print(f"{i:4d} {r['template']:<22s} seed {seed} verdict {r['named'] or r['verdict']} stat {r['max_statistic']:.3g}/{r['threshold']:.3g} "
              f"{r['seconds']:.1f} s | alarms {s['alarms']}/{s['replicates']}, upper95 {s['upper95_one_sided']:.3f}", flush=True)
    s = summarise(rows)
    write_scorecard([false_alarm_row(s["alarms"], s["replicates"], TARGET, f"{args.out.name}, seeds {args.first_seed}-{args.first_seed + len(rows) - 1}, "
                                     f"{args.samples} realisations")], args.out.with_suffix(".scorecard.csv"))
    print(f"false alarms {s['alarms']} / {s['replicates']} = {s['rate']:.3f}, 95 % interval [{s['ci95'][0]:.3f}, {s['ci95'][1]:.3f}], "
          f"one-sided upper bound {s['upper95_one_sided']:.3f} (target <= {TARGET}): {'holds' if s['holds'] else 'not shown'}")


if __name__ == "__main__":
    main()

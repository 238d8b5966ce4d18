"""The hidden-effect benchmark of the discrepancy workflow as data: per-case outcomes, the
confusion matrix, detection against magnitude, and the scorecard rows (accuracy, false alarms).
"""

from __future__ import annotations

from typing import Mapping, Sequence

import numpy as np
import xarray as xr

from .scorecard import ScoreRow

__all__ = ["case_outcome", "benchmark_dataset", "benchmark_rows"]


def case_outcome(label: Mapping, verdict: Mapping) -> dict:
    """One benchmark case: truth, verdict, whether it is right and whether the gap halved.

    Right means: ``none`` for a null case; for a hidden effect, the named effect or a member of
    the stated ambiguity set is the truth.
    """
    truth, named = str(label["effect"]), str(verdict["effect"])
    amb = list(verdict.get("ambiguous_with", []))
    correct = named == "none" if truth == "none" else (named == truth or truth in amb)
    before, after = float(verdict["gap_before"]), float(verdict["gap_after"])
    return {"case": str(label["name"]), "truth": truth, "magnitude": float(label.get("magnitude") or 0.0),
            "manoeuvre": str(label.get("manoeuvre", "")), "verdict": named, "ambiguous_with": ",".join(amb),
            "correct": bool(correct), "detected": named != "none", "gap_before": before, "gap_after": after,
            "gap_halved": bool(truth == "none" or after <= 0.5 * before),
            "mu_mean_before": float(verdict["distributions"]["before"]["mu"]["mean"]),
            "mu_mean_after": float(verdict["distributions"]["after"]["mu"]["mean"]),
            "seconds": float(verdict.get("evidence", {}).get("seconds", np.nan))}


def benchmark_dataset(outcomes: Sequence[Mapping]) -> xr.Dataset:
    """Outcomes (dim ``case``) and the confusion matrix (dims ``true_effect`` x ``named_effect``)."""
    cases = [o["case"] for o in outcomes]
    data = {k: ("case", [o[k] for o in outcomes]) for k in outcomes[0] if k != "case"}
    truths = sorted({o["truth"] for o in outcomes})
    named = sorted({o["verdict"] for o in outcomes} | set(truths))
    confusion = np.zeros((len(truths), len(named)), int)
    for o in outcomes:
        confusion[truths.index(o["truth"]), named.index(o["verdict"])] += 1
    ds = xr.Dataset(data, coords={"case": cases})
    ds["confusion"] = (("true_effect", "named_effect"), confusion, {"long_name": "benchmark cases by true and named effect"})
    ds = ds.assign_coords(true_effect=truths, named_effect=named)
    hidden = [o for o in outcomes if o["truth"] != "none"]
    null = [o for o in outcomes if o["truth"] == "none"]
    ds.attrs.update(accuracy=float(np.mean([o["correct"] for o in hidden])) if hidden else float("nan"),
                    false_alarm_rate=float(np.mean([o["detected"] for o in null])) if null else float("nan"),
                    gap_halved_rate=float(np.mean([o["gap_halved"] for o in hidden])) if hidden else float("nan"),
                    n_hidden=len(hidden), n_null=len(null))
    return ds


def benchmark_rows(ds: xr.Dataset, min_accuracy: float = 0.9, max_false_alarm: float = 0.2) -> list[ScoreRow]:
    """Scorecard rows of the benchmark (internal targets: ``uqdrive check``).

    The false-alarm target allows one false alarm in five null cases: at the family-wise level
    0.05 the chance of more than one among five is 2 %.
    """
    acc, fa, halved = float(ds.attrs["accuracy"]), float(ds.attrs["false_alarm_rate"]), float(ds.attrs["gap_halved_rate"])
    rows = [
        ScoreRow("discrepancy: hidden effects named (share)", "uqdrive check", 1.0, acc, 1.0 - min_accuracy, "pass" if acc >= min_accuracy else "fail"),
        ScoreRow("discrepancy: false alarms on null cases (share)", "uqdrive check", 0.0, fa, max_false_alarm, "pass" if fa <= max_false_alarm else "fail"),
        ScoreRow("discrepancy: gap halved by the named effect (share)", "uqdrive check", 1.0, halved, 1.0 - min_accuracy, "pass" if halved >= min_accuracy else "fail"),
    ]
    return rows

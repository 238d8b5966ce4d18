"""The judgement of a discover verdict against the reality that made the data, shared by the
benchmarks of independent realities (bench_real_tyres.py, bench_four_wheel.py) and their tables.

A verdict is *physical* when every named effect is one the reality has and the gap is at least
halved, or an `unrecognised` rest follows what is named, or `unrecognised` stands alone where no
candidate, fitted in the first forward step, closes half of the baseline's chi2 excess.
"""

from __future__ import annotations

import json
import resource
from pathlib import Path
from typing import Collection

#: The share of the baseline's chi2 excess a candidate must close for the acceptance to name it
#: (with the rest `unrecognised`): below it, `unrecognised` alone with the gap unchanged is right.
HALF = 0.5


def judge(row: dict, present: Collection[str]) -> str:
    """Physical, or what is wrong, for a summary ``row`` (``effects``, ``gap_before``,
    ``gap_after``, ``best`` from :func:`best_candidate`) of a reality whose effects are ``present``
    (the names a verdict may give, `unrecognised` included)."""
    named = [e["effect"] for e in row.get("effects") or []]
    wrong = [n for n in named if n not in present]
    if wrong:
        return f"names {', '.join(wrong)}, absent from the reality"
    best = row.get("best") or {}
    share = best.get("share_closed")
    if named == ["unrecognised"] and row["gap_after"] >= row["gap_before"]:
        if share is not None and share < HALF:
            return f"physical: `unrecognised`, no candidate closes half the chi2 excess (`{best['effect']}` {share:.2f})"
        return "`unrecognised` alone, gap unchanged"
    if row["gap_after"] <= 0.5 * row["gap_before"] or "unrecognised" in named or row["gap_before"] == 0:
        return "physical" + (f" (`{best['effect']}` alone closes {share:.2f} of the chi2 excess)" if share is not None else "")
    return "gap not halved"


def best_candidate(verdict: dict) -> dict:
    """The first forward step's best candidate of a ``verdict`` (its document) and the share of the
    baseline's chi2 excess it closes on the linear footing, as the acceptance judged it."""
    ev = verdict["evidence"]
    fits = {k: c for k, c in (ev.get("candidates") or {}).items() if "chi2_linear_footing" in c}
    if not fits:
        return {}
    name = min(fits, key=lambda k: fits[k]["chi2_linear_footing"])
    share = (ev["chi2_baseline"] - fits[name]["chi2_linear_footing"]) / ev["excess_chi2"] if ev.get("excess_chi2") else None
    return {"effect": name, "chi2": fits[name]["chi2_linear_footing"], "share_closed": None if share is None else round(share, 4)}


def verdict_row(verdict: dict) -> dict:
    """The parts of a ``verdict`` a benchmark records: the named effects with their intervals, the
    gaps, the forward steps' chi2 and the first step's best candidate."""
    row = {k: verdict.get(k) for k in ("effect", "effects", "gap_before", "gap_after", "warnings")}
    row["steps"] = [{k: s.get(k) for k in ("effect", "chi2", "explains") if k in s} for s in (verdict["evidence"].get("steps") or [])]
    row["best"] = best_candidate(verdict)
    return row


def effect_cell(e: dict) -> str:
    """Markdown of one named effect: its name and each parameter's value [95 % interval]."""
    params = ", ".join(f"{k} {v[0]:.3g} [{v[1]:.3g}, {v[2]:.3g}]" for k, v in e.get("parameters", {}).items() if isinstance(v, list))
    return f"`{e['effect']}`" + (f": {params}" if params else "")


def children_cpu() -> float:
    """CPU seconds (user + system) of this process' finished child processes."""
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def merged_rows(*records: Path | None) -> dict[str, dict]:
    """The rows of the summary ``records`` that exist, by case name; a later record's row replaces
    an earlier one's (a case run again)."""
    rows: dict[str, dict] = {}
    for record in records:
        if record is not None and record.exists():
            rows.update({r["name"]: r for r in json.loads(record.read_text())})
    return rows

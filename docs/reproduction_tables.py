"""The reproduction page's tables and quoted results, written at every docs build from the committed
scorecard record docs/measurements/scorecard.csv, with the thesis' values and the config's settings read from the code.

Refresh the record after `make reproduce` with `python tools/record_scorecard.py`.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

from generated_tables import _write

RECORD = Path(__file__).resolve().parent / "measurements" / "scorecard.csv"
TABLES = ("reproduction_table_6_2", "reproduction_posterior")

_T62 = "{est} {what} (thesis Table 6.2{variant})"
_RESIDUALS = (("SI (literal)", ""), ("unit-free", ", unit-free residuals"))
_BAYES_CASES = ("LST-LST", "LST-LST A=0.05")
_COVERAGE_ENSEMBLES = "posterior coverage of truth over independent ensembles (LST-LST)"
_PARAMETERS_PER_POSTERIOR = 6  # mu mean, mu std, l_f mean, l_f std, the wind's two bounds


class MissingScorecardRow(KeyError):
    """The page quotes a scorecard quantity the record does not hold."""


def scorecard(path: Path = RECORD) -> dict[str, dict[str, str]]:
    """The record's rows by their ``quantity``."""
    with open(path, newline="") as fh:
        return {r["quantity"]: r for r in csv.DictReader(fh)}


def value(rows: dict, quantity: str, column: str = "reproduced") -> float:
    """One number of the record; a missing row stops the build, naming the quantity."""
    if quantity not in rows:
        raise MissingScorecardRow(f"docs/measurements/scorecard.csv has no row '{quantity}' that docs/reproduction.md quotes; "
                                  "record a reproduction's scorecard with tools/record_scorecard.py")
    return float(rows[quantity][column])


def _interval(low: float, high: float) -> str:
    return f"U({low:.0f}, {high:.0f})"


def table_6_2(rows: dict) -> str:
    """Table 6.2's means and wind bounds with SI and unit-free residuals beside the thesis' values."""
    from uqdrive.studies.tables import THESIS_TABLE_6_2

    lines = ["| estimate | residuals | mu mean | l_f mean [m] | mean wind [N] |", "|---|---|---|---|---|"]
    for est in ("LST-STD", "NLST-STD"):
        for label, variant in _RESIDUALS:
            v = {w: value(rows, _T62.format(est=est, what=w, variant=variant))
                 for w in ("mu mean", "l_f mean", "wind lower bound", "wind upper bound")}
            lines.append(f"| {est} | {label} | {v['mu mean']:.3f} | {v['l_f mean']:.3f} | "
                         f"{_interval(v['wind lower bound'], v['wind upper bound'])} |")
        t = THESIS_TABLE_6_2[est]
        lines.append(f"| {est} | thesis Table 6.2 | {t[0]:.3f} | {t[2]:.3f} | {_interval(t[4], t[5])} |")
    return "\n".join(lines) + "\n"


def _of_six(share: float) -> str:
    return f"{round(share * _PARAMETERS_PER_POSTERIOR)} of {_PARAMETERS_PER_POSTERIOR}"


def posterior_table(rows: dict) -> str:
    """How many of each case's six 95 % posterior intervals hold the truth, and the NLST-LST verdict."""
    lines = ["| case | truth inside 95 % |", "|---|---|"]
    lines += [f"| {case} | {_of_six(value(rows, f'posterior coverage of truth ({case})'))} |" for case in _BAYES_CASES]
    wrong = value(rows, "posterior 95% interval of mu mean excludes the truth (NLST-LST: confidently wrong)") == 1.0
    lines.append(f"| NLST-LST | {'confidently wrong (mu mean)' if wrong else 'mu mean covered'} |")
    return "\n".join(lines) + "\n"


def _wilson(hits: int, n: int, z: float = 1.959964) -> tuple[float, float]:
    p = hits / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return centre - half, centre + half


def substitutions(rows: dict | None = None) -> dict[str, str]:
    """The results the page quotes in its text (``rep_*``) and the config settings it names (``cfg_*``)."""
    from uqdrive.config import load_config
    from uqdrive.studies.tables import THESIS_TABLE_6_3

    rows = scorecard() if rows is None else rows
    cfg = load_config(None)
    free62 = _T62.format(est="NLST-STD", what="wind {} bound", variant=", unit-free residuals")
    free63 = "NLST-STD wind {} bound (thesis Table 6.3, unit-free residuals)"
    lo62, hi62 = value(rows, free62.format("lower")), value(rows, free62.format("upper"))
    pub_lo, pub_hi = value(rows, free62.format("lower"), "published"), value(rows, free62.format("upper"), "published")
    excess = sorted((pub_lo - lo62, hi62 - pub_hi))
    trials = int(cfg["bayes"]["calibration_sets"]) * _PARAMETERS_PER_POSTERIOR
    hits = round(value(rows, _COVERAGE_ENSEMBLES) * trials)
    w_lo, w_hi = _wilson(hits, trials)
    t63 = THESIS_TABLE_6_3["NLST-STD"]
    return {
        "rep_nlst_wind_excess": f"{excess[0]:.0f}-{excess[1]:.0f}",
        "rep_nlst_mc0_mu": f"{value(rows, _T62.format(est='NLST-STD', what='mu mean', variant=', without the wind yaw moment')):.2f}",
        "rep_nlst_wind_6_2": _interval(lo62, hi62),
        "rep_nlst_wind_6_3": _interval(value(rows, free63.format("lower")), value(rows, free63.format("upper"))),
        "thesis_nlst_wind_6_3": _interval(t63[4], t63[5]),
        "rep_bayes_unit_free_inside": _of_six(value(rows, "posterior 95% interval contains optimiser estimate, unit-free residuals (LST-LST)")),
        "rep_bayes_si_inside": _of_six(value(rows, "posterior 95% interval contains optimiser estimate (LST-LST)")),
        "rep_coverage": f"{hits} of {trials} ({100 * hits / trials:.1f} %, Wilson 95 % interval [{100 * w_lo:.0f} %, {100 * w_hi:.0f} %])",
        "rep_coverage_sets": str(cfg["bayes"]["calibration_sets"]),
        "rep_discrepancy_mu": f"{value(rows, 'discrepancy: thesis case, emcee 95 % interval of the mu mean covers 1.0'):.2f}",
        "cfg_step_ms": f"{1000 * cfg['time']['step']:g}",
        "cfg_dt_ms": f"{1000 * cfg['time']['dt']:g}",
        "cfg_wind_sigma": f"{cfg['wind']['sigma']:g}",
        "cfg_samples": str(cfg["montecarlo"]["samples"]),
        "cfg_spin_threshold": f"{cfg['montecarlo']['spin_threshold']:g}",
        "cfg_M_c": f"{cfg['vehicle']['M_c']:g}",
    }


def write_all(outdir: Path) -> None:
    """Write the page's tables into ``outdir``."""
    rows = scorecard()
    _write(outdir / "reproduction_table_6_2.md", table_6_2(rows))
    _write(outdir / "reproduction_posterior.md", posterior_table(rows))

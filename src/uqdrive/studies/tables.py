"""Tables 6.2 and 6.3 of the thesis from the identification experiments, beside the published
values (with the variants past the thesis beside them), and the scorecard rows they support.
"""

from __future__ import annotations

from typing import Mapping

import numpy as np
import xarray as xr

from .scorecard import ScoreRow, compare

__all__ = ["THESIS_TABLE_6_2", "THESIS_TABLE_6_3", "THESIS_TABLES", "table_rows", "thesis_table_rows", "table_scorecard_rows"]

#: (mu mean, mu std, l_f mean, l_f std, wind low, wind high) per estimate, thesis Tables 6.2/6.3.
THESIS_TABLE_6_2 = {
    "LST-STD": (0.998, 0.202, 1.542, 0.196, -412.0, 419.0),
    "NLST-STD": (0.797, 0.192, 1.523, 0.222, -389.0, 608.0),
    "NLST-INP": (0.798, 0.192, 1.524, 0.223, -383.0, 603.0),
    "NLST-DST": (0.807, 0.199, 1.533, 0.213, -392.0, 596.0),
}
THESIS_TABLE_6_3 = {
    "NLST-STD": (0.796, 0.189, 1.514, 0.219, -370.0, 597.0),
    "NLST-INP": (0.796, 0.189, 1.513, 0.219, -374.0, 601.0),
    "NLST-DST": (0.805, 0.195, 1.523, 0.211, -378.0, 590.0),
}

#: Per table: the experiment of its thesis-faithful rows, the published values, and the
#: variant experiments (past the thesis) whose rows follow, each with its estimate-name suffix.
THESIS_TABLES = {
    "6.2": ("basic", THESIS_TABLE_6_2, (("no_wind_moment", " (M_c = 0)"), ("normalised", " (unit-free residuals)"))),
    "6.3": ("inverted", THESIS_TABLE_6_3, (("normalised_inverted", " (unit-free residuals)"),)),
}


def _fmt(t, s):
    return (f"N({t[0]:.3f}, {abs(t[1]):.3f})", f"N({t[2]:.3f}, {abs(t[3]):.3f})", f"U({t[4]:.0f}, {t[5]:.0f})",
            f"+-({s[0]:.3f}, {s[1]:.3f})", f"+-({s[2]:.3f}, {s[3]:.3f})", f"+-({s[4]:.0f}, {s[5]:.0f})")


def table_rows(ds: xr.Dataset, thesis: dict) -> list[dict]:
    """Mean estimate over the runs per estimate, its Gauss-Newton error, and the thesis' value."""
    rows = []
    for est in ds["estimate"].values:
        th = ds["theta"].sel(estimate=est).values
        ok = np.all(np.isfinite(th), axis=1)
        mean = th[ok].mean(axis=0)
        err = np.nanmean(ds["theta_std"].sel(estimate=est).values[ok], axis=0)
        mu, lf, wind, emu, elf, ewind = _fmt(mean, err)
        ref = thesis.get(str(est))
        rows.append({
            "estimate": str(est), "runs": int(ok.sum()), "mu": mu, "l_f [m]": lf, "F_w_mean [N]": wind,
            "GN error mu": emu, "GN error l_f": elf, "GN error wind": ewind,
            "thesis mu": f"N({ref[0]}, {ref[1]})" if ref else "", "thesis l_f": f"N({ref[2]}, {ref[3]})" if ref else "",
            "thesis wind": f"U({ref[4]:.0f}, {ref[5]:.0f})" if ref else "",
        })
    return rows


def thesis_table_rows(datasets: Mapping[str, xr.Dataset], which: str) -> list[dict]:
    """Rows of thesis Table 6.2 or 6.3, followed by the rows of the variants that were run.

    Parameters
    ----------
    datasets : mapping of str to xarray.Dataset
        Identification experiments by name (``basic``, ``inverted``, ``no_wind_moment``,
        ``normalised``, ``normalised_inverted``, ...), as written by the identification study.
        The table's own experiment is required; a variant missing here is left out.
    which : {"6.2", "6.3"}
        The table: 6.2 (basic test) or 6.3 (inverted steering).

    Returns
    -------
    list of dict
        The rows of :func:`table_rows` for the table's experiment; then, for 6.2, those of the
        experiment without the wind yaw moment, their estimates marked ``" (M_c = 0)"``; then
        those of the unit-free residuals (``normalised`` for 6.2, ``normalised_inverted`` for
        6.3), marked ``" (unit-free residuals)"``. Every variant is set beside the same
        published values.

    Raises
    ------
    ValueError
        If ``which`` names no table.
    KeyError
        If the table's own experiment is missing from ``datasets``.
    """
    if which not in THESIS_TABLES:
        raise ValueError(f"no thesis table '{which}'; choose one of {sorted(THESIS_TABLES)}")
    experiment, thesis, variants = THESIS_TABLES[which]
    rows = table_rows(datasets[experiment], thesis)
    for name, suffix in variants:
        if name in datasets:
            rows += [dict(r, estimate=r["estimate"] + suffix) for r in table_rows(datasets[name], thesis)]
    return rows


def table_scorecard_rows(basic: xr.Dataset, inverted: xr.Dataset, no_wind_moment: xr.Dataset | None = None,
                         normalised: xr.Dataset | None = None, normalised_inverted: xr.Dataset | None = None) -> list[ScoreRow]:
    """Scorecard rows of Tables 6.2/6.3: run-averaged means against the published ones.

    Tolerances from the issue: 0.02 (mu, LST), 0.03 (mu, NLST), 0.02 m (l_f), 30 N (wind).
    The variants (no wind yaw moment; unit-free residuals) get their own rows beside the
    thesis-faithful ones.
    """
    out = []
    cases = [(basic, THESIS_TABLE_6_2, "thesis Table 6.2"), (inverted, THESIS_TABLE_6_3, "thesis Table 6.3")]
    if no_wind_moment is not None:
        cases.append((no_wind_moment, THESIS_TABLE_6_2, "thesis Table 6.2, without the wind yaw moment"))
    if normalised is not None:
        cases.append((normalised, THESIS_TABLE_6_2, "thesis Table 6.2, unit-free residuals"))
    if normalised_inverted is not None:
        cases.append((normalised_inverted, THESIS_TABLE_6_3, "thesis Table 6.3, unit-free residuals"))
    for ds, table, src in cases:
        for est in ("LST-STD", "NLST-STD"):
            if est not in ds["estimate"].values or est not in table:
                continue
            th = np.nanmean(ds["theta"].sel(estimate=est).values, axis=0)
            ref = table[est]
            tol_mu = 0.02 if est.startswith("LST") else 0.03
            out += [
                compare(f"{est} mu mean ({src})", src, ref[0], th[0], tol_mu),
                compare(f"{est} l_f mean ({src})", src, ref[2], th[2], 0.02),
                compare(f"{est} wind lower bound ({src})", src, ref[4], th[4], 30.0),
                compare(f"{est} wind upper bound ({src})", src, ref[5], th[5], 30.0),
            ]
    out += [_inverted_shift_row(basic, inverted, "")]
    if normalised is not None and normalised_inverted is not None:
        out.append(_inverted_shift_row(normalised, normalised_inverted, ", unit-free residuals"))
    return out


def _inverted_shift_row(basic: xr.Dataset, inverted: xr.Dataset, label: str) -> ScoreRow:
    """Sec. 6.2.1.1: with inverted steering the wind estimate shifts the other way. By the odd
    symmetry of (5.3) the shift of the interval's midpoint from the truth flips sign; reproduced
    is 1 when it does (the thesis' own Table 6.3 midpoints, +110 and +114 N, do not flip)."""
    def shift(ds):
        th = np.nanmean(ds["theta"].sel(estimate="NLST-STD").values, axis=0)
        truth = ds["truth"].values
        return 0.5 * (th[4] + th[5]) - 0.5 * (truth[4] + truth[5])

    flipped = float(np.sign(shift(basic)) == -np.sign(shift(inverted)) != 0)
    return compare(f"NLST-STD wind estimate shifts the other way with inverted steering{label}", "thesis sec. 6.2.1.1 (text)", 1.0, flipped, 0.0)

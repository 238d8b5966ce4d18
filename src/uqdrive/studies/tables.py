"""Tables 6.2 and 6.3 of the thesis from the identification experiments, beside the published
values (with the variants past the thesis beside them), and the scorecard rows they support.
"""

from __future__ import annotations

from typing import Mapping

import numpy as np
import xarray as xr

from .scorecard import UQDRIVE_CHECK, ScoreRow, compare

__all__ = ["THESIS_TABLE_6_2", "THESIS_TABLE_6_3", "THESIS_TABLES", "table_rows", "thesis_table_rows", "table_scorecard_rows", "TABLE_TOLERANCE", "NLST_WIND_EXCESS"]

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


#: Tolerances of the Table 6.2/6.3 rows (issue 4): mu mean 0.02 (LST) and 0.03 (NLST), l_f mean
#: 0.02 m, wind bounds 30 N; a registered wider NLST wind interval may exceed the thesis' by at
#: most NLST_WIND_EXCESS (docs/reproduction.md: 35-65 N), on the wide side only.
TABLE_TOLERANCE = {"LST mu": 0.02, "NLST mu": 0.03, "l_f": 0.02, "wind": 30.0}
NLST_WIND_EXCESS = 100.0
#: theta index and label of the scorecard's quantities.
_PARAMETERS = ((0, "mu mean"), (2, "l_f mean"), (4, "wind lower bound"), (5, "wind upper bound"))


def _case_values(ds: xr.Dataset, est: str) -> np.ndarray:
    return np.nanmean(ds["theta"].sel(estimate=est).values, axis=0)


def table_scorecard_rows(basic: xr.Dataset, inverted: xr.Dataset, no_wind_moment: xr.Dataset | None = None,
                         normalised: xr.Dataset | None = None, normalised_inverted: xr.Dataset | None = None) -> list[ScoreRow]:
    """Scorecard rows of Tables 6.2/6.3: run-averaged means against the published ones.

    Tolerances: :data:`TABLE_TOLERANCE`. Every row's ``source`` is the thesis table whose number
    it holds; the variants (no wind yaw moment; unit-free residuals) are named in the quantity.
    Registered deviations (:data:`~uqdrive.studies.scorecard.KNOWN_DEVIATIONS`), decided in this
    order:

    * ``table_6_3_mirror`` (NLST wind bounds of Table 6.3): the bound lies nearer the mirror image
      of the thesis' Table 6.2 interval than the Table 6.3 value;
    * ``nlst_wind_wider`` (NLST wind bounds of Table 6.2, unit-free residuals): wider than the
      thesis' on that side, by at most :data:`NLST_WIND_EXCESS`;
    * ``si_residuals`` (every other row with SI residuals, thesis-faithful or M_c = 0): the same
      quantity with unit-free residuals is not ``fail``.

    The rows of the midpoint shift under inverted steering (internal, ``uqdrive check``) follow.
    """
    plan = [(basic, "6.2", ""), (inverted, "6.3", ""), (no_wind_moment, "6.2", ", without the wind yaw moment"),
            (normalised, "6.2", ", unit-free residuals"), (normalised_inverted, "6.3", ", unit-free residuals")]
    tables = {"6.2": THESIS_TABLE_6_2, "6.3": THESIS_TABLE_6_3}
    unit_free, si = {}, []
    order = []
    for ds, which, variant in plan:
        if ds is None:
            continue
        for est in ("LST-STD", "NLST-STD"):
            if est not in ds["estimate"].values or est not in tables[which]:
                continue
            th, ref = _case_values(ds, est), tables[which][est]
            for i, label in _PARAMETERS:
                quantity = f"{est} {label} (thesis Table {which}{variant})"
                tol = TABLE_TOLERANCE[est.split("-")[0] + " mu"] if i == 0 else TABLE_TOLERANCE["l_f" if i == 2 else "wind"]
                args = (quantity, f"thesis Table {which}", ref[i], th[i], tol)
                order.append(quantity)
                if est == "NLST-STD" and i in (4, 5) and which == "6.3":
                    mirror = -THESIS_TABLE_6_2[est][9 - i]  # (-high, -low) of Table 6.2
                    unit_free[quantity] = compare(*args, deviation="table_6_3_mirror", holds=abs(th[i] - mirror) < abs(th[i] - ref[i]))
                elif variant == ", unit-free residuals":
                    wider = (th[i] - ref[i]) * (1 if i == 5 else -1)
                    rule = {"deviation": "nlst_wind_wider", "holds": 0 < wider <= NLST_WIND_EXCESS} if est == "NLST-STD" and i in (4, 5) else {}
                    unit_free[quantity] = compare(*args, **rule)
                else:
                    si.append((args, f"{est} {label} (thesis Table {which}, unit-free residuals)"))
    rows = dict(unit_free)
    for args, counterpart in si:
        rows[args[0]] = compare(*args, deviation="si_residuals", holds=counterpart in unit_free and unit_free[counterpart].status != "fail")
    out = [rows[q] for q in order]
    out.append(_inverted_shift_row(basic, inverted, ""))
    if normalised is not None and normalised_inverted is not None:
        out.append(_inverted_shift_row(normalised, normalised_inverted, ", unit-free residuals"))
    return out


def _inverted_shift_row(basic: xr.Dataset, inverted: xr.Dataset, label: str) -> ScoreRow:
    """Sec. 6.2.1.1 says the wind estimate shifts the other way with inverted steering; by the odd
    symmetry of (5.3) the shift of the interval's midpoint from the truth must flip sign. An
    internal target (the thesis' own Table 6.3 midpoints, +110 and +114 N, do not flip):
    reproduced is 1 when it flips."""
    def shift(ds):
        th = _case_values(ds, "NLST-STD")
        truth = ds["truth"].values
        return 0.5 * (th[4] + th[5]) - 0.5 * (truth[4] + truth[5])

    flipped = float(np.sign(shift(basic)) == -np.sign(shift(inverted)) != 0)
    return compare(f"NLST-STD wind estimate shifts the other way with inverted steering{label}", UQDRIVE_CHECK, 1.0, flipped, 0.0)

"""The summary of a parameter sweep: each point's metrics read from its outputs, and one dataset
and table of them (a row a point) with the swept values and each point's provenance."""

from __future__ import annotations

import csv
import json
import warnings
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np
import xarray as xr
import yaml

from ..._version import __version__
from .spec import Sweep

__all__ = ["point_metrics", "summary_dataset", "summary_rows", "numeric_axis"]


def _attrs(path: Path) -> dict:
    with xr.open_dataset(path) as ds:
        return dict(ds.attrs)


def _nanmedian(x) -> float:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        return float(np.nanmedian(np.asarray(x, float))) if np.size(x) else float("nan")


def _identification(ds: xr.Dataset, group: str) -> dict:
    """Per estimate: median over runs of the normalised W2 of each distribution and of each
    identified parameter, and the share of converged runs."""
    out = {}
    for est in map(str, ds["estimate"].values):
        for d in map(str, ds["distribution"].values):
            out[f"{group}/w2_{d}/{est}"] = _nanmedian(ds["w2"].sel(estimate=est, distribution=d).values)
        for p in map(str, ds["parameter"].values):
            out[f"{group}/{p}/{est}"] = _nanmedian(ds["theta"].sel(estimate=est, parameter=p).values)
        out[f"{group}/converged/{est}"] = float(np.mean(ds["converged"].sel(estimate=est).values))
    return out


def point_metrics(collect: Sequence[str], outdir: str | Path, config: Mapping[str, Any]) -> dict[str, float]:
    """Metrics of one point, named ``group/quantity/series`` (series: a model, an estimate...)."""
    root, out = Path(outdir), {}
    for group in collect:
        if group == "stability":
            for m in config["montecarlo"]["models"]:
                for s in config["montecarlo"]["steers"]:
                    a = _attrs(root / f"data/ensemble_{m}_{s}.nc")
                    out[f"stability/n_spun/{m} {s}"] = float(a["n_spun"])
                    with xr.open_dataset(root / f"data/ensemble_{m}_{s}.nc") as ds:
                        out[f"stability/spun_share/{m} {s}"] = float(a["n_spun"]) / ds.sizes["sample"]
        elif group == "kl":
            with xr.open_dataset(root / "data/kl_nlst_lst.nc") as ds:
                kl = ds["kl_divergence"]
                for state in map(str, kl["state"].values):
                    out[f"kl/max/{state}"] = float(kl.sel(state=state).max())
                    out[f"kl/time_mean/{state}"] = float(kl.sel(state=state).mean())
        elif group == "control":
            for model in ("lst", "nlst"):
                with xr.open_dataset(root / f"data/control_mc_{model}.nc") as ds:
                    for c in map(str, ds["controller"].values):
                        out[f"control/unstable_runs/{model.upper()} {c}"] = float((1 - ds["stable"].sel(controller=c).values).sum())
        elif group == "wheelslip":
            for n in config["wheelslip"]["gp"]["training_sizes"]:
                g, c = _attrs(root / f"data/wheelslip_gp_{n}.nc"), _attrs(root / f"data/wheelslip_calibration_{n}.nc")
                series = f"{n} points"
                out[f"wheelslip/E_Gamma/{series}"] = float(g["E_Gamma"])
                out[f"wheelslip/std_Gamma/{series}"] = float(np.sqrt(g["var_Gamma"]))
                out[f"wheelslip/slope_error/{series}"] = float(abs(g["E_Gamma"] - g["true_Gamma"]))
                out[f"wheelslip/ml_coverage/{series}"] = c["ml_hits"] / max(int(c["ml_sets"]), 1)
                out[f"wheelslip/prior_coverage/{series}"] = c["prior_hits"] / max(int(c["prior_sets"]), 1)
            cl = _attrs(root / "data/wheelslip_closed_loop.nc")
            out["wheelslip/closed_loop_stable"] = float(cl["fraction_stable"])
            out["wheelslip/closed_loop_in_damping_band"] = float(cl["fraction_in_band"])
        elif group == "scorecard":
            with open(root / "scorecard.csv", newline="") as fh:
                statuses = [r["status"] for r in csv.DictReader(fh)]
            for s in sorted({"pass", "fail", *statuses}):
                out[f"scorecard/rows/{s}"] = float(statuses.count(s))
        else:
            name = group.split(".", 1)[1]
            with xr.open_dataset(root / f"data/identification_{name}.nc") as ds:
                out.update(_identification(ds.load(), group))
    return out


# --- the summary of a sweep ---------------------------------------------------------------------

def numeric_axis(values: Sequence[Any]) -> tuple[np.ndarray | None, str]:
    """A numeric axis for the values one key takes over the points: the numbers themselves, or
    for equal-length lists of numbers differing in one position that position (``[i]``);
    (None, "") when the values are not numbers (a categorical axis)."""
    def number(v):
        return isinstance(v, (int, float)) and not isinstance(v, bool)

    if all(number(v) for v in values):
        return np.asarray(values, float), ""
    if all(isinstance(v, (list, tuple)) and v and all(number(x) for x in v) for v in values) and len({len(v) for v in values}) == 1:
        arr = np.asarray(values, float)
        varying = [i for i in range(arr.shape[1]) if np.unique(arr[:, i]).size > 1]
        if len(varying) == 1:
            return arr[:, varying[0]], f"[{varying[0]}]"
    return None, ""


def _flow(value: Any) -> str:
    return yaml.safe_dump(value, default_flow_style=True, width=10**6).strip().removesuffix("...").strip()


def summary_dataset(sweep: Sweep, points: Sequence[Mapping[str, Any]]) -> xr.Dataset:
    """The summary of a sweep: ``value`` (point, metric), the swept values (as YAML text and as a
    numeric axis where there is one) and each point's provenance.

    ``points``: per point of the sweep, in order, the mapping written by the workflow
    (``name``, ``metrics``: name -> float, ``provenance``: config, config_hash, seed, version).
    """
    names = [p["name"] for p in points]
    metrics = list(dict.fromkeys(m for p in points for m in p["metrics"]))
    value = np.array([[p["metrics"].get(m, np.nan) for m in metrics] for p in points], float).reshape(len(points), len(metrics))
    parts = [m.split("/") + [""] * (3 - len(m.split("/"))) for m in metrics]
    swept = {p.name: p.values for p in sweep.points}
    axes = {k: numeric_axis([swept[n][k] for n in names]) for k in sweep.keys}
    prov = {f: [str(p["provenance"][f]) for p in points] for f in ("config", "config_hash", "uqdrive_version")}
    return xr.Dataset(
        {
            "value": (("point", "metric"), value, {"long_name": "metric of each point (see metric_group, metric_quantity, metric_series)"}),
            "swept_value": (("point", "key"), np.array([[_flow(swept[n][k]) for k in sweep.keys] for n in names], dtype=str).reshape(len(names), len(sweep.keys))),
            "swept_axis": (("point", "key"), np.array([[np.nan if axes[k][0] is None else axes[k][0][i] for k in sweep.keys] for i in range(len(names))], float).reshape(len(names), len(sweep.keys)),
                           {"long_name": "numeric value of each swept key (NaN: not a number; see axis_index)"}),
            "config": ("point", prov["config"]), "config_hash": ("point", prov["config_hash"]),
            "seed": ("point", np.array([int(p["provenance"]["seed"]) for p in points], np.int64)),
            "uqdrive_version": ("point", prov["uqdrive_version"]),
        },
        coords={"point": names, "metric": metrics, "key": list(sweep.keys), "axis_index": ("key", [axes[k][1] for k in sweep.keys]),
                "metric_group": ("metric", [p[0] for p in parts]), "metric_quantity": ("metric", [p[1] for p in parts]),
                "metric_series": ("metric", [p[2] for p in parts])},
        attrs={"title": f"sweep {sweep.name}", "sweep": sweep.name, "description": sweep.description, "base": sweep.base_path,
               "mode": sweep.mode, "set": json.dumps(sweep.fixed), "collect": ", ".join(sweep.collect), "uqdrive_version": __version__},
    )


def summary_rows(ds: xr.Dataset) -> list[dict]:
    """Rows of ``summary.csv``: a point each, with its swept values, metrics and provenance."""
    rows = []
    for i, name in enumerate(map(str, ds["point"].values)):
        row: dict[str, Any] = {"point": name}
        row.update({str(k): str(ds["swept_value"].values[i, j]) for j, k in enumerate(ds["key"].values)})
        row.update({str(m): f"{v:.6g}" for m, v in zip(ds["metric"].values, ds["value"].values[i])})
        row.update({f: str(ds[f].values[i]) for f in ("config", "config_hash", "seed", "uqdrive_version")})
        rows.append(row)
    return rows

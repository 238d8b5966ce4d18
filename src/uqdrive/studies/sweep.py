"""Parameter sweeps: any config value swept from one file, one summary (a row a point) per sweep.

A sweep file (``config/sweeps/<name>.yaml``)::

    description: one paragraph for the report
    base: config/config.yaml        # optional (this default); relative to the working directory
    set:                            # optional: dotted key -> value, for every point
      montecarlo.samples: 1000
    grid:                           # dotted key -> values: every combination; or `zip:` lists
      steering.delta_max_deg: [2.5, 5.0, 7.5]   # of equal length, taken together
    collect: [stability, kl, identification.basic]

Every point is the base config with ``set`` and its own values, validated like any config, and
runs the workflow into its own folder; ``collect`` names the metric groups (:data:`COLLECTORS`)
read from each point's outputs into the summary.
"""

from __future__ import annotations

import csv
import itertools
import json
import re
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np
import xarray as xr
import yaml

from .._version import __version__
from ..config import ConfigError, load_config, override_config, validate_config
from .identification import EXPERIMENTS

__all__ = ["SweepError", "SweepPoint", "Sweep", "COLLECTORS", "load_sweep", "parse_sweep", "expand_points", "point_name",
           "collect_targets", "point_metrics", "summary_dataset", "summary_rows", "numeric_axis"]

COLLECTORS = ("stability", "kl", "control", "wheelslip", "scorecard") + tuple(f"identification.{e}" for e in EXPERIMENTS)
_FIELDS = {"description", "base", "set", "grid", "zip", "collect"}


class SweepError(ValueError):
    """A sweep file is malformed, names an unknown key or collector, or gives an invalid value."""


@dataclass(frozen=True)
class SweepPoint:
    """One point: its folder name and the value of each swept key."""

    name: str
    values: dict


@dataclass(frozen=True)
class Sweep:
    """A parsed sweep: the base config (validated), fixed and swept settings, metric groups."""

    name: str
    description: str
    base_path: str
    base: dict
    fixed: dict
    mode: str
    keys: tuple
    points: tuple
    collect: tuple

    def point(self, name: str) -> SweepPoint:
        for p in self.points:
            if p.name == name:
                return p
        raise SweepError(f"sweep '{self.name}' has no point '{name}'; its points: {', '.join(p.name for p in self.points)}")

    def point_config(self, name: str, outdir: str) -> dict:
        """The resolved config of point ``name`` writing into ``outdir`` (validated)."""
        return _resolve(self, self.point(name), outdir)


def _fmt(value: Any) -> str:
    if isinstance(value, bool) or not isinstance(value, (int, float, list, tuple)):
        return str(value)
    if isinstance(value, (list, tuple)):
        return ",".join(_fmt(v) for v in value)
    return f"{value:g}"


def point_name(index: int, values: Mapping[str, Any]) -> str:
    """Folder name of a point: its index and its values, e.g. ``p01_delta_max_deg=5``."""
    slug = "_".join(f"{key.rsplit('.', 1)[-1]}={_fmt(v)}" for key, v in values.items())
    slug = re.sub(r"[^A-Za-z0-9._=,+-]", "-", slug)[:80]
    return f"p{index:02d}_{slug}" if slug else f"p{index:02d}"


def expand_points(mode: str, axes: Mapping[str, Sequence[Any]]) -> list[dict]:
    """The value of every swept key at each point: ``grid`` every combination (the last key
    fastest), ``zip`` the i-th value of every list together (lists of equal length)."""
    if not axes:
        raise SweepError(f"'{mode}' names no key; give at least one dotted key with its values")
    for key, values in axes.items():
        if not isinstance(values, (list, tuple)) or not values:
            raise SweepError(f"'{mode}.{key}' must be a non-empty list of values")
    keys = list(axes)
    if mode == "grid":
        return [dict(zip(keys, combo)) for combo in itertools.product(*(axes[k] for k in keys))]
    if mode == "zip":
        lengths = {k: len(v) for k, v in axes.items()}
        if len(set(lengths.values())) != 1:
            raise SweepError(f"'zip' lists must have equal lengths; got {lengths}")
        return [dict(zip(keys, combo)) for combo in zip(*(axes[k] for k in keys))]
    raise SweepError(f"unknown sweep mode '{mode}'; use 'grid' or 'zip'")


def _resolve(sweep: Sweep, point: SweepPoint, outdir: str) -> dict:
    try:
        cfg = override_config(sweep.base, {**sweep.fixed, **point.values})
    except KeyError as err:
        raise SweepError(f"sweep '{sweep.name}': {err.args[0]}; sweep only keys of the config") from None
    cfg["outdir"] = str(outdir)
    try:
        return validate_config(cfg)
    except ConfigError as err:
        raise SweepError(f"sweep '{sweep.name}', point {point.name}: {err}") from None


def parse_sweep(data: Any, name: str, base: Mapping[str, Any], base_path: str = "config/config.yaml") -> Sweep:
    """A :class:`Sweep` from the mapping of a sweep file, on the validated ``base`` config; every
    point's config is resolved and validated here, so a bad value fails before any job runs."""
    if not isinstance(data, Mapping):
        raise SweepError(f"sweep '{name}' must be a mapping with 'grid' or 'zip' and 'collect'")
    unknown = sorted(set(data) - _FIELDS)
    if unknown:
        raise SweepError(f"sweep '{name}': unknown field(s) {', '.join(unknown)}; allowed: {', '.join(sorted(_FIELDS))}")
    modes = [m for m in ("grid", "zip") if m in data]
    if len(modes) != 1:
        raise SweepError(f"sweep '{name}' needs exactly one of 'grid' (every combination) or 'zip' (lists taken together)")
    mode, axes, fixed = modes[0], data[modes[0]] or {}, data.get("set") or {}
    if not isinstance(axes, Mapping) or not isinstance(fixed, Mapping):
        raise SweepError(f"sweep '{name}': '{mode}' and 'set' map dotted config keys to values")
    for key in [*axes, *fixed]:
        if key == "outdir":
            raise SweepError(f"sweep '{name}': 'outdir' is set per point (results/sweeps/{name}/<point>); do not sweep it")
    both = sorted(set(axes) & set(fixed))
    if both:
        raise SweepError(f"sweep '{name}': {', '.join(both)} both swept and set")
    collect = data.get("collect")
    if isinstance(collect, str):
        collect = [collect]
    if not collect or not isinstance(collect, list):
        raise SweepError(f"sweep '{name}': 'collect' must list the metric groups to collect, from: {', '.join(COLLECTORS)}")
    bad = [c for c in collect if c not in COLLECTORS]
    if bad:
        raise SweepError(f"sweep '{name}': unknown collector(s) {', '.join(map(str, bad))}; choose from: {', '.join(COLLECTORS)}")
    points = tuple(SweepPoint(point_name(i, v), v) for i, v in enumerate(expand_points(mode, axes)))
    sweep = Sweep(name, str(data.get("description") or "").strip(), str(base_path), dict(base), dict(fixed), mode,
                  tuple(axes), points, tuple(dict.fromkeys(collect)))
    for p in points:
        _resolve(sweep, p, f"results/sweeps/{name}/{p.name}")
    return sweep


def load_sweep(path: str | Path, search: Sequence[str | Path] = (".",)) -> Sweep:
    """Read and check a sweep file; its ``base`` is looked up in the folders ``search``, in order."""
    path = Path(path)
    try:
        data = yaml.safe_load(path.read_text())
    except OSError as exc:
        raise SweepError(f"cannot read sweep file '{path}': {exc.strerror or exc}") from None
    except yaml.YAMLError as exc:
        raise SweepError(f"sweep file '{path}' is not valid YAML: {' '.join(str(exc).split())}") from None
    base_path = str((data or {}).get("base", "config/config.yaml")) if isinstance(data, Mapping) else "config/config.yaml"
    found = next((Path(d) / base_path for d in search if (Path(d) / base_path).is_file()), Path(base_path))
    try:
        base = load_config(found)
    except ConfigError as err:
        raise SweepError(f"sweep '{path.stem}': base config: {err}") from None
    return parse_sweep(data, path.stem, base, base_path)


# --- metrics of one point ---------------------------------------------------------------------

def collect_targets(collect: Sequence[str], config: Mapping[str, Any]) -> list[str]:
    """Output files (relative to the point's outdir) the metric groups ``collect`` read."""
    files: list[str] = []
    for group in collect:
        if group == "stability":
            files += [f"data/ensemble_{m}_{s}.nc" for m in config["montecarlo"]["models"] for s in config["montecarlo"]["steers"]]
        elif group == "kl":
            files.append("data/kl_nlst_lst.nc")
        elif group == "control":
            files += ["data/control_mc_lst.nc", "data/control_mc_nlst.nc"]
        elif group == "wheelslip":
            sizes = config["wheelslip"]["gp"]["training_sizes"]
            files += [f"data/wheelslip_gp_{n}.nc" for n in sizes] + [f"data/wheelslip_calibration_{n}.nc" for n in sizes]
            files.append("data/wheelslip_closed_loop.nc")
        elif group == "scorecard":
            files.append("scorecard.csv")
        elif group.startswith("identification."):
            files.append(f"data/{group.replace('.', '_')}.nc")
        else:
            raise SweepError(f"unknown collector '{group}'; choose from: {', '.join(COLLECTORS)}")
    return list(dict.fromkeys(files))


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

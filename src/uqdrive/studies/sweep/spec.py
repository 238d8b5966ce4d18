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
read from each point's outputs into the summary (:mod:`uqdrive.studies.sweep.summary`). This module
reads no dataset: the workflow imports it while it parses its rules.
"""

from __future__ import annotations

import itertools
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping, Sequence

import yaml

from ..._yaml import load_yaml
from ...config import ConfigError, load_config, override_config, validate_config
from ..experiments import EXPERIMENTS

__all__ = ["SweepError", "SweepPoint", "Sweep", "COLLECTORS", "load_sweep", "parse_sweep", "expand_points", "point_name",
           "collect_targets"]

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
        """The point called ``name``; ``SweepError`` if the sweep has none."""
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
        data = load_yaml(path.read_text())
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

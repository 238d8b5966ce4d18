"""``--model DIR/model.yaml``: the augmented model written by ``uqdrive discover`` (the baseline
LST plus named effects with fitted parameters), for ``uqdrive simulate`` and ``uqdrive identify``.
"""

from __future__ import annotations

import json
import math
import numbers
from dataclasses import replace
from pathlib import Path
from typing import Any, Mapping

import numpy as np
import xarray as xr
import yaml

from .._version import __version__
from .._yaml import load_yaml
from ..config import config_hash
from ..inference.discrepancy.band import moment_statistics, statistic_scale
from ..inference.discrepancy.fit import StructureFit
from ..inference.sampling import run_influence, sampling_errors
from ..io import DataError, check_run_count, read_ensemble, speed_profile
from ..rng import rng_stream
from ..vehicle.augmented import AugmentedSimulator
from ..vehicle.channels import CHANNELS
from ..vehicle.effects import EFFECTS, ModelStructure, structure_from_effects
from ..vehicle.montecarlo import STEERS, spin_mask
from ..vehicle.noise import estimate_noise_variance
from ..vehicle.single_track import STATE_NAMES, STATE_UNITS, STATES, steering_input
from ..settings import Normal, Settings, Vehicle
from ..vehicle_spec import OPTIONAL_QUANTITIES

__all__ = ["is_model_file", "load_model", "check_effects", "check_distributions", "MODEL_DISTRIBUTIONS", "model_settings", "simulate_model", "identify_with_model"]


def is_model_file(value: str) -> bool:
    """Whether a ``--model`` value names a model file (``.yaml``/``.yml``) rather than a built-in model."""
    return value.endswith((".yaml", ".yml"))


#: The distributions of a model file: name -> its two parameters with their range (low, high, low
#: inclusive, high inclusive, unit). The ranges are the config's physical ranges of the same quantities.
MODEL_DISTRIBUTIONS = {
    "mu": {"mean": (0.0, 10.0, False, True, "-"), "std": (0.0, 10.0, True, True, "-")},
    "l_f": {"mean": (0.0, 20.0, False, False, "m"), "std": (0.0, 20.0, True, True, "m")},
    "F_w_mean": {"low": (-1e5, 1e5, True, True, "N"), "high": (-1e5, 1e5, True, True, "N")},
    "m_load": {"mean": (0.0, 1e5, True, True, "kg"), "std": (0.0, 1e5, True, True, "kg")},
}
_OPTIONAL = ("m_load",)


def _number(value) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


def _span(lo, hi, lo_in, hi_in) -> str:
    return f"{'[' if lo_in else '('}{lo:g}, {hi:g}{']' if hi_in else ')'}"


def check_effects(effects, where: str) -> dict:
    """``{effect: {parameter: value}}`` of a model file checked against the registry
    (:data:`uqdrive.vehicle.effects.EFFECTS`): known names, each parameter present once, a finite
    number inside the registry's bounds in the registry's unit. A :class:`DataError` naming the
    effect, the parameter, its unit and the fix otherwise."""
    example = "effects: {actuator_lag: {T: 0.05}}"
    if effects is None:
        return {}
    if not isinstance(effects, Mapping):
        raise DataError(f"{where}: 'effects' is a {type(effects).__name__}; map each effect to its parameters ({example}), "
                        "or leave it empty for the baseline")
    out = {}
    for name, params in effects.items():
        if name not in EFFECTS:
            raise DataError(f"{where}: effect '{name}' is unknown; known effects: {', '.join(sorted(EFFECTS))}")
        e = EFFECTS[name]
        form = "{" + ", ".join(f"{p}: <{'number' if u == '-' else u}>" for p, u in zip(e.parameters, e.units)) + "}"
        if not isinstance(params, Mapping):
            raise DataError(f"{where}: effect '{name}' is {params!r}, not its parameters; write {name}: {form}")
        unknown = [p for p in params if p not in e.parameters]
        missing = [p for p in e.parameters if p not in params]
        if unknown or missing:
            what = f"has no parameter '{unknown[0]}'" if unknown else f"lacks parameter '{missing[0]}'"
            raise DataError(f"{where}: effect '{name}' {what}; write {name}: {form}")
        for p, unit, (lo, hi) in zip(e.parameters, e.units, e.bounds):
            v = params[p]
            unit_ = "" if unit == "-" else f" {unit}"
            if not _number(v) or not math.isfinite(v) or not lo <= v <= hi:
                got = f"{v!r} is not a number" if not _number(v) else f"{v:g}{unit_} is outside [{lo:g}, {hi:g}]{unit_}"
                raise DataError(f"{where}: effect '{name}' parameter {p} = {got}; give a finite number in [{lo:g}, {hi:g}]{unit_}")
        out[name] = {p: float(params[p]) for p in e.parameters}
    return out


def check_distributions(dist, where: str, wheelbase: float | None = None) -> dict:
    """The distributions of a model file checked: mu, l_f (mean, std), F_w_mean (low, high) and
    optionally m_load (mean, std), each a finite number in its physical range (:data:`MODEL_DISTRIBUTIONS`),
    low <= high, and the l_f mean inside the ``wheelbase`` (m) where given."""
    form = "distributions: {mu: {mean: 1.0, std: 0.1}, l_f: {mean: 1.5, std: 0.1}, F_w_mean: {low: -500, high: 500}}"
    if not isinstance(dist, Mapping):
        raise DataError(f"{where}: 'distributions' is a {type(dist).__name__}; write them as a mapping, {form}")
    for name in dist:
        if name not in MODEL_DISTRIBUTIONS:
            raise DataError(f"{where}: distribution '{name}' is unknown; give {', '.join(MODEL_DISTRIBUTIONS)} ({form})")
    out = {}
    for name, fields in MODEL_DISTRIBUTIONS.items():
        if name not in dist:
            if name in _OPTIONAL:
                continue
            raise DataError(f"{where}: distribution '{name}' is missing; give all of mu, l_f and F_w_mean ({form})")
        d = dist[name]
        want = "{" + ", ".join(f"{f}: <{'number' if r[-1] == '-' else r[-1]}>" for f, r in fields.items()) + "}"
        if not isinstance(d, Mapping) or set(d) != set(fields):
            raise DataError(f"{where}: distribution '{name}' is {d!r}; write {name}: {want}")
        for f, (lo, hi, lo_in, hi_in, unit) in fields.items():
            v = d[f]
            unit_ = "" if unit == "-" else f" {unit}"
            inside = _number(v) and math.isfinite(v) and (lo <= v if lo_in else lo < v) and (v <= hi if hi_in else v < hi)
            if not inside:
                got = f"{v!r} is not a number" if not _number(v) else f"{v:g}{unit_} is outside {_span(lo, hi, lo_in, hi_in)}{unit_}"
                raise DataError(f"{where}: distributions.{name}.{f} = {got}; give a finite number in "
                                f"{_span(lo, hi, lo_in, hi_in)}{unit_}" + (" (0: known)" if f == "std" else ""))
        out[name] = {f: float(d[f]) for f in fields}
    if out["F_w_mean"]["low"] > out["F_w_mean"]["high"]:
        raise DataError(f"{where}: distributions.F_w_mean.low = {out['F_w_mean']['low']:g} N exceeds high = "
                        f"{out['F_w_mean']['high']:g} N; swap them")
    if wheelbase is not None and not out["l_f"]["mean"] < wheelbase:
        raise DataError(f"{where}: distributions.l_f.mean = {out['l_f']['mean']:g} m lies beyond the wheelbase {wheelbase:g} m; "
                        "give the distance from the centre of gravity to the front axle, inside the wheelbase")
    return out


def load_model(path: str | Path, config: Mapping[str, Any] | None = None) -> tuple[ModelStructure, dict]:
    """The structure and the distributions of a ``model.yaml``, checked against the effect
    registry and the distributions' ranges (:func:`check_effects`, :func:`check_distributions`;
    with ``config``, the l_f mean inside its wheelbase and the constants each effect needs given
    by its car); a one-line DataError otherwise.
    ``simulate``, ``identify`` and ``discover`` read every model file through it."""
    path = Path(path)
    try:
        doc = load_yaml(path.read_bytes().decode("utf-8-sig"))
    except (OSError, UnicodeDecodeError, yaml.YAMLError, RecursionError) as exc:
        reason = getattr(exc, "strerror", None) or " ".join(str(exc).split())
        raise DataError(f"cannot read model file '{path}': {reason}; give the model.yaml that uqdrive discover wrote") from None
    if not isinstance(doc, dict) or doc.get("baseline") != "lst" or "distributions" not in doc:
        raise DataError(f"'{path}' is not a uqdrive model file (needs baseline: lst, effects, distributions); write one with `uqdrive discover`")
    where = f"model file '{path}'"
    if doc.get("uqdrive_model", 1) != 1:
        raise DataError(f"{where}: uqdrive_model = {doc['uqdrive_model']!r}; this uqdrive reads version 1: write it again with "
                        "this version's `uqdrive discover`")
    effects = check_effects(doc.get("effects"), where)
    dist = check_distributions(doc["distributions"], where, None if config is None else float(config["vehicle"]["wheelbase"]))
    car = None if config is None else Vehicle.from_sections(config["vehicle"], config.get("tyre", {}), dist["l_f"]["mean"])
    for name in effects if car is not None else ():  # discover names no effect the car lacks constants for: nor may a model
        for key in EFFECTS[name].missing(car):
            unit, meaning = OPTIONAL_QUANTITIES[key]
            raise DataError(f"{where}: effect '{name}' needs the car's {key} ({meaning}, {unit}), which this car does not give; "
                            "add it to the vehicle file (or the config's vehicle section), or pass the car the model was made for")
    return structure_from_effects(effects), dist


def _theta(d: Mapping[str, Any]):
    return [d["mu"]["mean"], d["mu"]["std"], d["l_f"]["mean"], d["l_f"]["std"], d["F_w_mean"]["low"], d["F_w_mean"]["high"]]


def model_settings(settings: Settings, dist: Mapping[str, Mapping[str, float]]) -> Settings:
    """The settings of a run of a model file: the config's ``settings`` with the file's load
    distribution (``dist`` as :func:`check_distributions` returns it) where the file gives one."""
    if "m_load" not in dist:
        return settings
    load = Normal(dist["m_load"]["mean"], dist["m_load"]["std"])
    return replace(settings, uncertainty=replace(settings.uncertainty, m_load=load))


def simulate_model(config: Mapping[str, Any], path: Path, steer: str, samples: int, seed: int, backend: str = "numpy") -> xr.Dataset:
    """An ensemble of the augmented model in the data schema (the thesis' input (5.5)/(5.7)),
    its non-linear model integrated by ``backend`` (:class:`~uqdrive.vehicle.dynamics.engine.EnsembleSimulator`'s)."""
    structure, dist = load_model(path, config)
    settings = model_settings(Settings.from_config(config), dist)
    t_end, dt = config["time"]["t_end"], config["time"]["dt"]
    t = np.arange(int(round(t_end / dt)) + 1) * dt
    st = config["steering"]
    delta = steering_input(t, np.deg2rad(st["delta_max_deg"]), st["period"], STEERS[steer])
    v_c = config["vehicle"]["speed_kmh"] / 3.6
    sim = AugmentedSimulator.drawn(settings, t, delta, v_c, samples, rng_stream(seed, "parameters"), backend=backend)
    x = sim.simulate(_theta(dist), structure)
    spun = spin_mask(x[2], config["montecarlo"]["spin_threshold"])
    data = {s: (("sample", "time"), x[i], {"units": STATE_UNITS[s], "long_name": STATE_NAMES[s]}) for i, s in enumerate(STATES)}
    data["delta"] = ("time", delta, {"units": "rad", "long_name": "front steering angle (commanded)"})
    data["spun"] = ("sample", spun.astype(np.int8), {"units": "1", "long_name": "lost control"})
    attrs = {"title": f"uqdrive ensemble of the augmented model {path}", "model": "augmented", "effects": json.dumps(dict(structure.effects)),
             "steer": steer, "v_c": float(v_c), "noise_A": 0.0, "n_spun": int(spun.sum()), "seed": int(seed),
             "config_hash": config_hash(config), "uqdrive_version": __version__}
    coords = {"sample": np.arange(samples), "time": ("time", t, {"units": "s", "long_name": "time"})}
    return xr.Dataset(data, coords=coords, attrs=attrs)


def identify_with_model(config: Mapping[str, Any], measured, path: Path, out: Path | None, model_samples: int = 1000):
    """Identify mu, l_f and the mean wind with the augmented model (its effects held at their
    fitted values) on common random numbers; write ``out/estimate.json`` and ``out/fit.png``
    with the fields of plain ``uqdrive identify`` (warnings, standard errors, intervals, the
    goodness of fit, ``converged`` by the same rules).

    The residuals are the gaps in units of the statistics' sampling scale, which already holds
    the model's own Monte Carlo error (factor 1 + n / model_samples); the standard errors and the
    misfit's reference take the realisations' influences with that factor.

    ``measured`` is a file or a validated xarray.Dataset; with ``out`` None nothing is written and
    the summary comes back with ``draw(path=None)``, which draws fit.png (a Figure without a path).
    """
    from ..plots.fit import fit_figure
    from .identify import fit_notes, fit_status, fit_warnings, write_outputs

    structure, dist = load_model(path, config)
    ds = measured if isinstance(measured, xr.Dataset) else read_ensemble(measured)
    measured = ds.attrs.get("source", "dataset") if isinstance(measured, xr.Dataset) else measured
    check_run_count(ds.sizes["sample"], str(measured), "identify")
    missing = [s for s in STATES if s not in ds]
    if missing or speed_profile(ds) is not None:
        raise DataError(f"{measured}: identify --model simulates all four states at one speed and this file "
                        f"{'lacks ' + ', '.join(missing) if missing else 'has a changing v'}: identify it without --model")
    if "v_c" not in ds.attrs:
        ds.attrs["v_c"] = float(np.ravel(ds["v"].values)[0])
    channels = tuple(c for c in CHANNELS if c in ds)  # the four states, and a_y where measured (fitted as discover does)
    x = np.stack([np.asarray(ds[s].values, float) for s in channels])
    thr = config["montecarlo"]["spin_threshold"]
    spun = spin_mask(x[2], thr)
    keep = ~spun if config["montecarlo"]["spin_policy"] == "exclude" else np.ones_like(spun)
    if keep.sum() < 2:
        raise DataError(f"{measured}: fewer than 2 realisations kept control; nothing to identify")
    x = x[:, keep]
    t = ds["time"].values
    noise = np.array([estimate_noise_variance(x[i], order=4) for i in range(len(channels))])
    stride = max(1, int(np.ceil((t.size - 1) / 150)))
    settings = model_settings(Settings.from_config(config), dist)
    sim = AugmentedSimulator.drawn(settings, t, ds["delta"].values, float(ds.attrs["v_c"]), model_samples, rng_stream(config["seed"], "discrepancy_model"), stride=stride,
                                   interpolation=str(ds["delta"].attrs.get("interpolation", "linear")), channels=channels)
    x = x[:, :, : sim.time.size : stride]
    index = np.arange(1, x.shape[-1])
    measured_stats = moment_statistics(x, index)
    ratio = x.shape[1] / model_samples
    scale = statistic_scale(x, index, model_ratio=ratio)
    fit = StructureFit(sim, index, noise, thr if config["montecarlo"]["spin_policy"] == "exclude" else None, base=structure)
    theta0 = _theta(dist)
    fit.fit(measured_stats, scale, theta0)
    th = fit.theta_
    names = tuple(fit.parameter_names)
    bounds = list(zip(*fit.parameter_bounds))
    influence = run_influence(x[:, :, index], tuple((1.0 + ratio) / scale[k] ** 2 for k in range(2)))
    lo, _ = fit.parameter_bounds
    zero = [i for i, n in enumerate(names) if n.endswith("_std") and th[i] <= lo[i] + 1e-6]
    se, upper, ref = sampling_errors(fit.jacobian_, influence, th, zero, rng_stream(config["seed"], "identify_reference"))
    upper = {names[i]: u for i, u in upper.items()}
    warnings_ = fit_warnings(th, theta0, bounds, names, bool(fit.success_), fit.message_, standard_errors=se, reference=ref,
                             cost=fit.chi2_, n_runs=int(keep.sum()))
    z = 1.959963984540054
    intervals = {n: [0.0, upper[n]] if n in upper else ([float(v - z * e), float(v + z * e)] if np.isfinite(e) else [None, None])
                 for n, v, e in zip(names, th, se)}
    finite = lambda v: float(v) if np.isfinite(v) else None  # noqa: E731
    summary = {"mu": [float(th[0]), float(th[1])], "l_f": [float(th[2]), float(th[3])], "F_w_mean": [float(th[4]), float(th[5])],
               "cost": fit.chi2_, "converged": bool(fit.success_) and not warnings_, "optimiser_converged": bool(fit.success_),
               "model_fits": bool(fit.chi2_ <= ref.threshold), "warnings": warnings_,
               "notes": fit_notes(names, th, bounds, upper), "iterations": int(fit.nfev_),
               "fixed": {"m_load": float(settings.uncertainty.m_load.mean)},
               "standard_errors": {k: [finite(se[2 * i]), finite(se[2 * i + 1])] for i, k in enumerate(("mu", "l_f", "F_w_mean"))},
               "intervals_95": intervals,
               "goodness_of_fit": {"misfit": float(fit.chi2_), "expected": finite(ref.expected), "ratio": finite(fit.chi2_ / ref.expected),
                                   "threshold": finite(ref.threshold), "level": ref.level, "p_value": finite(ref.p_value(fit.chi2_)),
                                   "dof": finite(ref.dof), "passed": bool(fit.chi2_ <= ref.threshold)},
               "model": str(path), "effects": {name: dict(p) for name, p in structure.effects}, "samples": int(spun.size),
               "samples_used": int(keep.sum()), "n_spun": int(spun.sum()), "spun_indices": [int(i) for i in np.flatnonzero(spun)],
               "message": fit.message_, "measured": str(measured)}
    time = sim.output_time[index]
    model_stats = fit.statistics_
    status = fit_status(summary)
    draw = lambda p=None: fit_figure(time, measured_stats[0], measured_stats[1], (model_stats[0], model_stats[1]), p,  # noqa: E731
                                     title="Identified augmented model vs measured ensemble", channels=channels, status=status)
    if out is None:
        return summary, draw
    write_outputs(out, summary, draw)
    return summary

"""Load and validate the uqdrive configuration (one JSON schema for workflow and CLI).

Errors name the offending key (dotted) and say how to fix it; a config hash goes into provenance.
Beyond the schema: every number finite, physical ranges of what the models read
(:data:`PHYSICAL_RANGES`) and cross-field checks. The default configuration ships inside the
package (``default_config.yaml``: the repository's ``config/config.yaml`` searching every candidate).
A validated config holds the car in the model's internal terms: a ``vehicle_file`` is applied and
the vehicle section's engineering keys are converted by :mod:`uqdrive.vehicle_spec`.
"""

from __future__ import annotations

import copy
import functools
import hashlib
import json
import math
from importlib.resources import files
from pathlib import Path
from typing import Any, Mapping

import yaml

from ._errors import ConfigError
from ._yaml import load_yaml
from .vehicle_spec import ENGINEERING_KEYS, FILE_KEY_HINTS, apply_vehicle_file, check_plausible, derived_from, normalise_vehicle, vehicle_names  # noqa: F401
from .vehicle_spec import read_vehicle_file as _read_vehicle_file

__all__ = ["ConfigError", "load_config", "validate_config", "read_vehicle_file", "vehicle_names", "config_hash", "load_schema", "default_config_text",
           "PHYSICAL_RANGES", "DEFAULT_CONFIG_NAME", "config_value", "restrict_config", "merge_config", "override_config",
           "parse_overrides", "provenance", "read_config_mapping"]

#: Name of the packaged default configuration (a copy of config/config.yaml).
DEFAULT_CONFIG_NAME = "default_config.yaml"
_MAX = 2**63 - 1  # largest seed netCDF attributes and numpy seed sequences share

#: Physical range of each value the models read: key -> (low, high, low inclusive, high
#: inclusive, unit). Wider than any vehicle, so that only unit slips and typos land outside.
#: A std of 0 (and a mean wind with low == high) declares the quantity known
#: (:meth:`uqdrive.settings.Uncertainty.known`).
PHYSICAL_RANGES: dict[str, tuple[float, float, bool, bool, str]] = {
    "seed": (0, _MAX, True, True, ""),
    "vehicle.m_base": (0.0, 1e5, False, True, "kg"),
    "vehicle.J0": (0.0, 100.0, False, True, "m^2"),
    "vehicle.wheelbase": (0.0, 20.0, False, True, "m"),
    "vehicle.c_Sf": (0.0, 1e3, False, True, ""),
    "vehicle.c_Sr": (0.0, 1e3, False, True, ""),
    "vehicle.speed_kmh": (1.8, 360.0, True, True, "km/h"),
    "vehicle.M_c": (-100.0, 100.0, True, True, "m"),
    "vehicle.g": (0.0, 100.0, False, True, "m/s^2"),
    "tyre.C": (0.0, 10.0, False, True, ""),
    "tyre.E": (-100.0, 1.0, True, True, ""),
    "uncertainty.mu.mean": (0.0, 10.0, False, True, ""),
    "uncertainty.mu.std": (0.0, 10.0, True, True, ""),
    "uncertainty.m_load.mean": (0.0, 1e5, True, True, "kg"),
    "uncertainty.m_load.std": (0.0, 1e5, True, True, "kg"),
    "uncertainty.l_f.std": (0.0, 20.0, True, True, "m"),
    "uncertainty.F_w_mean.low": (-1e5, 1e5, True, True, "N"),
    "uncertainty.F_w_mean.high": (-1e5, 1e5, True, True, "N"),
    "wind.sigma": (0.0, 1e5, True, True, "N"),
    "wind.Tc": (0.0, 1e4, False, True, "s"),
    "steering.period": (0.0, 1e4, False, True, "s"),
    "time.t_end": (0.0, 1e5, False, True, "s"),
    "time.dt": (0.0, 1e3, False, True, "s"),
    "time.step": (0.0, 1e3, False, True, "s"),
    "montecarlo.samples": (2, 10**7, True, True, ""),
    "montecarlo.spin_threshold": (0.0, 1e4, False, True, "rad"),
    "identification.max_iter": (1, 10**5, True, True, ""),
}
_MAX_TIME_POINTS = 10**6  # t_end / step: beyond it one trajectory does not fit in memory


def load_schema() -> dict:
    """Return the JSON schema shipped with the package (``config_schema.yaml``)."""
    return copy.deepcopy(_schema())


@functools.lru_cache(maxsize=1)
def _schema() -> dict:
    return load_yaml(files("uqdrive").joinpath("config_schema.yaml").read_text())


@functools.lru_cache(maxsize=1)
def _validator():
    from jsonschema import Draft202012Validator  # here: the settings and the simulators import without jsonschema
    return Draft202012Validator(_schema())


def default_config_text() -> str:
    """The packaged default configuration as text (with its comments), for editing."""
    return files("uqdrive").joinpath(DEFAULT_CONFIG_NAME).read_text(encoding="utf-8")


def _key(path) -> str:
    return ".".join(str(p) for p in path) or "<top level>"


def _check_leaves(node, path=(), where: str = "config key '{}'") -> None:
    """Mapping keys are names and every number is finite (YAML .nan and .inf parse as floats)."""
    if isinstance(node, Mapping):
        for k, v in node.items():
            if not isinstance(k, str):
                raise ConfigError(f"{where.format(_key(path + (k,)))} is not a name; write keys as text")
            _check_leaves(v, path + (k,), where)
    elif isinstance(node, list):
        for i, v in enumerate(node):
            _check_leaves(v, path + (i,), where)
    elif isinstance(node, float) and not math.isfinite(node):
        raise ConfigError(f"{where.format(_key(path))} is {node}; give a finite number")


_FIXES = {
    "minimum": lambda e: f"give a value >= {e.validator_value}",
    "exclusiveMinimum": lambda e: f"give a value > {e.validator_value}",
    "maximum": lambda e: f"give a value <= {e.validator_value}",
    "exclusiveMaximum": lambda e: f"give a value < {e.validator_value}",
    "type": lambda e: (f"write it as a mapping {{{', '.join(f'{k}: ...' for k in e.schema['properties'])}}}"
                       if e.validator_value == "object" and e.schema.get("properties") else
                       f"write a plain {e.validator_value} (digits and a decimal point, no unit or separators)"
                       if e.validator_value in ("number", "integer") else f"give a value of type {e.validator_value}"),
    "enum": lambda e: "choose one of " + ", ".join(map(str, e.validator_value)),
    "minItems": lambda e: f"give at least {e.validator_value} item(s)",
    "maxItems": lambda e: f"give at most {e.validator_value} item(s)",
    "uniqueItems": lambda e: "remove the repeated items",
    "minLength": lambda e: "give a non-empty value",
    "oneOf": lambda e: "give " + " or ".join(f"'{s['const']}'" if "const" in s else f"a list of {', '.join(map(str, s['items']['enum']))}" if "enum" in s.get("items", {}) else str(s.get("type")) for s in e.validator_value),
}


def _unit(dotted: str) -> str:
    """The unit of a config key for messages ("" if it has none or is not known)."""
    if dotted in PHYSICAL_RANGES:
        return PHYSICAL_RANGES[dotted][-1]
    parts = dotted.split(".")
    return ENGINEERING_KEYS.get(parts[1] if parts[0] == "vehicle" and len(parts) > 1 else parts[0], ("",))[0]


def _schema_error(error, where: str = "config key '{}'") -> ConfigError:
    path = list(error.absolute_path)
    name = lambda p: where.format(_key(p))  # noqa: E731
    if error.validator == "additionalProperties":
        extra = sorted(map(str, set(error.instance) - set(error.schema.get("properties", {}))))
        allowed = ", ".join(sorted(error.schema.get("properties", {})))
        return ConfigError(f"{name(path + extra[:1])} is not known; allowed keys under '{_key(path)}' are: {allowed}")
    if error.validator == "required":
        missing = [k for k in error.validator_value if isinstance(error.instance, Mapping) and k not in error.instance][:1]
        if where.startswith("vehicle file") and missing:
            unit = _unit("vehicle." + _key(path)) if path else ""
            hint = FILE_KEY_HINTS.get(missing[0], f"{missing[0]}" + (f" ({unit})" if unit and unit != "-" else ""))
            return ConfigError(f"{name(path + missing)} is missing; add {hint}")
        return ConfigError(f"{name(path + missing)} is missing; add it (the default: uqdrive config --dump -)")
    fix = _FIXES.get(error.validator)
    unit = _unit(_key(path) if where.startswith("config") else "vehicle." + _key(path))
    return ConfigError(f"{name(path)}{f' ({unit})' if unit and unit != '-' else ''}: {error.message}" + (f"; {fix(error)}" if fix else ""))


def validate_config(config: Mapping[str, Any]) -> dict:
    """Validate a configuration mapping; return a deep copy of it.

    Raises
    ------
    ConfigError
        Naming the first offending key (dotted path), the value and the fix.
    """
    if not isinstance(config, Mapping):
        raise ConfigError("the configuration must be a mapping of keys")
    cfg = copy.deepcopy(dict(config))
    _check_leaves(cfg)
    from jsonschema.exceptions import best_match
    error = best_match(_validator().iter_errors(cfg))
    if error is not None:
        raise _schema_error(error)
    reference = cfg.pop("vehicle_file", None)
    if reference is not None:
        name, spec = read_vehicle_file(reference)
        cfg = apply_vehicle_file(cfg, spec, name)
        origin = {k: f"vehicle file '{reference}': {v}" for k, v in derived_from(spec).items()}
        origin.update({f"vehicle.{k}": f"vehicle file '{reference}': {k}" for k in ("wheelbase", "M_c", "cg_height", "track_width") if k in spec})
    else:
        origin = {k: f"the config's vehicle section ({v})" for k, v in derived_from(cfg["vehicle"]).items()}
    cfg = normalise_vehicle(cfg)
    _check_ranges(cfg, origin)
    _check_semantics(cfg)
    return cfg


def _get(cfg: Mapping, key: str):
    node = cfg
    for part in key.split("."):
        node = node[part]
    return node


def _check_ranges(cfg: dict, origin: Mapping[str, str] = {}) -> None:  # noqa: B006 - read only
    """Every value in :data:`PHYSICAL_RANGES`, the car's sizes a car's (:func:`check_plausible`); a value derived
    from the car's engineering keys (``origin``: config key -> the user's words) is named by the keys the user wrote."""
    for key, (lo, hi, lo_in, hi_in, unit) in PHYSICAL_RANGES.items():
        value = _get(cfg, key)
        ok = (lo <= value if lo_in else lo < value) and (value <= hi if hi_in else value < hi)
        if not ok:
            span = f"{'[' if lo_in else '('}{lo:g}, {hi:g}{']' if hi_in else ')'}"
            if key in origin:
                raise ConfigError(f"{origin[key]} gives the model's {key.split('.')[-1]} = {value:g}{' ' + unit if unit else ''}, "
                                  f"outside its range {span}; check those values and their units")
            raise ConfigError(f"config key '{key}' = {value:g} is outside the physical range {span}{' ' + unit if unit else ''}; "
                              "give a value in that range")
    for key, quantity in {"m_base": "mass", "wheelbase": "wheelbase", "cg_height": "cg_height", "track_width": "track_width"}.items():
        if f"vehicle.{key}" not in origin and cfg["vehicle"].get(key) is not None:  # a vehicle file's: by its own key
            check_plausible(quantity, cfg["vehicle"][key], f"config key 'vehicle.{key}'")


def _check_semantics(cfg: dict) -> None:
    """Cross-field checks a JSON schema cannot express."""
    unc, veh, tim = cfg["uncertainty"], cfg["vehicle"], cfg["time"]
    if not unc["F_w_mean"]["low"] <= unc["F_w_mean"]["high"]:
        raise ConfigError("config key 'uncertainty.F_w_mean.low' must not exceed 'high'; swap them")
    if not 0.0 < unc["l_f"]["mean"] < veh["wheelbase"]:
        raise ConfigError(
            f"config key 'uncertainty.l_f.mean' = {unc['l_f']['mean']:g} must lie inside (0, vehicle.wheelbase = {veh['wheelbase']:g}) m"
        )
    for name, outer, inner in (("time.dt", tim["t_end"], tim["dt"]), ("time.step", tim["dt"], tim["step"])):
        ratio = outer / inner
        if abs(ratio - round(ratio)) > 1e-9 * max(1.0, ratio) or round(ratio) < 1:
            raise ConfigError(
                f"config key '{name}' = {inner} must divide {outer} into a whole number of steps"
            )
    if tim["t_end"] < 2 * tim["dt"] * (1 - 1e-9):
        raise ConfigError(f"config key 'time.t_end' = {tim['t_end']:g} s must be at least 2 time.dt = {2 * tim['dt']:g} s "
                          "(3 time points); raise t_end or lower dt")
    if tim["t_end"] / tim["step"] > _MAX_TIME_POINTS:
        raise ConfigError(f"config key 'time.step' = {tim['step']:g} s makes {tim['t_end'] / tim['step']:.3g} steps "
                          f"(more than {_MAX_TIME_POINTS:.0e}); raise time.step or lower time.t_end")
    ramp, (lo, hi) = cfg["montecarlo"].get("speed_profile") or {}, PHYSICAL_RANGES["vehicle.speed_kmh"][:2]
    for key in [k for k in ("start_kmh", "end_kmh") if ramp and not lo <= ramp[k] <= hi][:1]:  # a forward speed, as speed_kmh
        raise ConfigError(f"config key 'montecarlo.speed_profile.{key}' = {ramp[key]:g} km/h is outside [{lo:g}, {hi:g}] km/h; give a forward speed in that range")
    if ramp and ramp.get("t_start", 0.0) >= tim["t_end"]:
        raise ConfigError(f"config key 'montecarlo.speed_profile.t_start' = {ramp['t_start']:g} s is not before time.t_end = {tim['t_end']:g} s, so the speed never changes; give an earlier start")
    if math.isclose(cfg["wind"]["kle_truncation"], 0.0):
        raise ConfigError("config key 'wind.kle_truncation' must be positive")


def read_vehicle_file(reference: str | Path) -> tuple[str, dict]:
    """The name and the checked content of a vehicle file: a packaged name or a YAML file's path
    (:func:`uqdrive.vehicle_spec.read_vehicle_file`), validated by the schema's ``$defs/vehicle_file``."""
    return _read_vehicle_file(reference, _check_vehicle_schema)


def _check_vehicle_schema(spec: dict, label: str) -> None:
    _check_leaves(spec, where=label)
    from jsonschema.exceptions import best_match
    error = best_match(_vehicle_validator().iter_errors(spec))
    if error is not None:
        raise _schema_error(error, label)


@functools.lru_cache(maxsize=1)
def _vehicle_validator():
    from jsonschema import Draft202012Validator
    schema = _schema()
    return Draft202012Validator({"$defs": schema["$defs"], **schema["$defs"]["vehicle_file"]})


def load_config(path: str | Path | None = None, vehicle: str | Path | None = None) -> dict:
    """Read a YAML configuration file (None: the packaged default) and validate it; ``vehicle`` (a
    packaged vehicle name or a vehicle file) replaces the car as the ``vehicle_file`` key does (ConfigError otherwise)."""
    data = read_config_mapping(path)
    if vehicle is not None:
        data["vehicle_file"] = str(vehicle)
    elif path is not None and isinstance(data.get("vehicle_file"), str):
        data["vehicle_file"] = _beside(Path(path), data["vehicle_file"])
    return validate_config(data)


def read_config_mapping(path: str | Path | None) -> dict:
    """The unvalidated mapping of a config file (None: the packaged one); ConfigError names the file and the fault."""
    if path is None:
        name, text = f"<packaged {DEFAULT_CONFIG_NAME}>", default_config_text()
    else:
        name = path = Path(path)
        try:
            raw = path.read_bytes()
        except OSError as exc:
            raise ConfigError(f"cannot read config file '{path}': {exc.strerror or exc}; give a config's path (uqdrive config --dump FILE writes one)") from exc
        try:
            text = raw.decode("utf-8-sig")
        except UnicodeDecodeError as exc:
            raise ConfigError(f"config file '{path}' is not UTF-8 text (byte 0x{raw[exc.start]:02x} at offset {exc.start}); save it as UTF-8") from None
    try:
        data = load_yaml(text)
    except (yaml.YAMLError, RecursionError) as exc:
        raise ConfigError(f"config file '{name}' is not valid YAML: {' '.join(str(exc).split())}") from None
    if not isinstance(data, dict):
        raise ConfigError(f"config file '{name}' must hold a mapping of keys (start from: uqdrive config --dump FILE)")
    return data


def _beside(config_path: Path, reference: str) -> str:
    """A config's ``vehicle_file`` path, relative to the config file's folder; a packaged name, an
    absolute path, and a path found only from the working directory (a workflow's) stay as given."""
    ref = Path(reference)
    if ref.is_absolute() or not (reference.endswith((".yaml", ".yml")) or "/" in reference):
        return reference
    beside = config_path.parent / ref
    return str(beside) if beside.exists() or not ref.exists() else reference


def config_value(config: Mapping[str, Any], key: str) -> Any:
    """The value of the dotted ``key`` (e.g. ``"montecarlo.samples"``) in ``config``.

    Raises
    ------
    KeyError
        Naming the key and the first part of it that ``config`` lacks.
    """
    node: Any = config
    parts = key.split(".")
    for i, part in enumerate(parts):
        if not isinstance(node, Mapping) or part not in node:
            raise KeyError(f"config key '{key}' does not exist (no '{'.'.join(parts[: i + 1])}')")
        node = node[part]
    return node


def restrict_config(config: Mapping[str, Any], keys) -> dict:
    """The part of ``config`` under ``keys`` (sections or dotted keys), nested as in ``config``.

    ``restrict_config(cfg, ["seed", "montecarlo.samples"])`` is ``{"seed": ..., "montecarlo":
    {"samples": ...}}``; values are deep copies. A key ``config`` lacks raises :class:`KeyError`.
    """
    out: dict = {}
    for key in keys:
        value = copy.deepcopy(config_value(config, key))
        parts = key.split(".")
        node = out
        for part in parts[:-1]:
            node = node.setdefault(part, {})
        node[parts[-1]] = value
    return out


def merge_config(base: Mapping[str, Any], overrides: Mapping[str, Any]) -> dict:
    """A deep copy of ``base`` with ``overrides`` merged in: mappings key by key (recursively),
    any other value replaced (as Snakemake merges ``--configfile`` and ``--config``)."""
    out = copy.deepcopy(dict(base))
    for key, value in overrides.items():
        if isinstance(value, Mapping) and isinstance(out.get(key), Mapping):
            out[key] = merge_config(out[key], value)
        else:
            out[key] = copy.deepcopy(value)
    return out


def override_config(config: Mapping[str, Any], settings: Mapping[str, Any]) -> dict:
    """A deep copy of ``config`` with each dotted key of ``settings`` set to its value; every key
    must exist in ``config`` already (a misspelt key is an error, not a new key)."""
    out = copy.deepcopy(dict(config))
    for key, value in settings.items():
        config_value(out, key)
        *parents, leaf = key.split(".")
        node = out
        for part in parents:
            node = node[part]
        node[leaf] = copy.deepcopy(value)
    return out


def parse_overrides(entries) -> dict:
    """Nested overrides from ``key=value`` entries (Snakemake's ``--config`` arguments), each value
    read as YAML: ``control={"R": 50}`` gives ``{"control": {"R": 50}}`` with R a number, where
    Snakemake itself would keep the nested 50 a string. Dotted keys nest too (``control.R=50``).

    Raises
    ------
    ConfigError
        If an entry has no ``=`` or its value is not YAML.
    """
    out: dict = {}
    for entry in entries or ():
        key, sep, text = str(entry).partition("=")
        if not sep or not key:
            raise ConfigError(f"config override '{entry}' must read key=value")
        try:
            value = load_yaml(text) if text else None
        except yaml.YAMLError as exc:
            raise ConfigError(f"config override '{key}': the value is not YAML: {exc}") from exc
        for part in reversed(key.split(".")):
            value = {part: value}
        out = merge_config(out, value)
    return out


def _canonical(value: Any) -> Any:
    """Settings as plain JSON values; an integral float equals its int (2.0 and 2 hash alike)."""
    if isinstance(value, Mapping):
        return {str(k): _canonical(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_canonical(v) for v in value]
    if isinstance(value, float) and value.is_integer():
        return int(value)
    return value


def config_hash(config: Mapping[str, Any], keys=None) -> str:
    """Return a short SHA-256 of the canonical JSON form of the settings (provenance).

    The settings are ``config`` restricted to the dotted ``keys`` if given, else all of it but
    ``outdir`` (where results go is not a setting). The one hash of uqdrive: the CLI, the
    workflow's datasets and the scorecard all call it, so equal settings give equal hashes.
    """
    settings = restrict_config(config, keys) if keys is not None else {k: v for k, v in config.items() if k != "outdir"}
    canonical = json.dumps(_canonical(settings), sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.sha256(canonical.encode()).hexdigest()[:16]


def provenance(config: Mapping[str, Any], source: str) -> dict:
    """What a product traces to: the config's ``source`` (path, with any overrides), its
    :func:`config_hash`, the root seed and the uqdrive version."""
    from ._version import __version__

    return {"config": str(source), "config_hash": config_hash(config), "seed": int(config["seed"]), "uqdrive_version": __version__}

"""Load and validate the uqdrive configuration (one JSON schema for workflow and CLI).

Errors name the offending key and say how to fix it; a config hash goes into provenance.
"""

from __future__ import annotations

import copy
import hashlib
import json
import math
from importlib.resources import files
from pathlib import Path
from typing import Any, Mapping

import yaml
from jsonschema import Draft202012Validator
from jsonschema.exceptions import best_match

__all__ = ["ConfigError", "load_config", "validate_config", "config_hash", "load_schema"]


class ConfigError(ValueError):
    """A configuration value is missing, misspelt, of the wrong type or out of range."""


def load_schema() -> dict:
    """Return the JSON schema shipped with the package (``config_schema.yaml``)."""
    return yaml.safe_load(files("uqdrive").joinpath("config_schema.yaml").read_text())


def _key(path) -> str:
    return ".".join(str(p) for p in path) or "<top level>"


def validate_config(config: Mapping[str, Any]) -> dict:
    """Validate a configuration mapping; return a deep copy of it.

    Raises
    ------
    ConfigError
        Naming the first offending key (dotted path) and the expected value.
    """
    cfg = copy.deepcopy(dict(config))
    validator = Draft202012Validator(load_schema())
    error = best_match(validator.iter_errors(cfg))
    if error is not None:
        path = list(error.absolute_path)
        if error.validator == "additionalProperties":
            extra = sorted(set(error.instance) - set(error.schema.get("properties", {})))
            allowed = ", ".join(sorted(error.schema.get("properties", {})))
            raise ConfigError(
                f"config key '{_key(path + extra[:1])}' is not known; "
                f"allowed keys under '{_key(path)}' are: {allowed}"
            )
        raise ConfigError(f"config key '{_key(path)}': {error.message}")
    _check_semantics(cfg)
    return cfg


def _check_semantics(cfg: dict) -> None:
    """Cross-field checks a JSON schema cannot express."""
    unc, veh, tim = cfg["uncertainty"], cfg["vehicle"], cfg["time"]
    if not unc["F_w_mean"]["low"] <= unc["F_w_mean"]["high"]:
        raise ConfigError("config key 'uncertainty.F_w_mean.low' must not exceed 'high'")
    if not 0.0 < unc["l_f"]["mean"] < veh["wheelbase"]:
        raise ConfigError(
            "config key 'uncertainty.l_f.mean' must lie inside (0, vehicle.wheelbase)"
        )
    for name, outer, inner in (("time.dt", tim["t_end"], tim["dt"]), ("time.step", tim["dt"], tim["step"])):
        ratio = outer / inner
        if abs(ratio - round(ratio)) > 1e-9 * max(1.0, ratio) or round(ratio) < 1:
            raise ConfigError(
                f"config key '{name}' = {inner} must divide {outer} into a whole number of steps"
            )
    if math.isclose(cfg["wind"]["kle_truncation"], 0.0):
        raise ConfigError("config key 'wind.kle_truncation' must be positive")


def load_config(path: str | Path) -> dict:
    """Read a YAML configuration file and validate it.

    Raises
    ------
    ConfigError
        If the file is missing, is not YAML, or fails validation.
    """
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as exc:
        raise ConfigError(f"cannot read config file '{path}': {exc.strerror}") from exc
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise ConfigError(f"config file '{path}' is not valid YAML: {exc}") from exc
    if not isinstance(data, dict):
        raise ConfigError(f"config file '{path}' must hold a mapping of keys")
    return validate_config(data)


def config_hash(config: Mapping[str, Any]) -> str:
    """Return a short SHA-256 of the canonical JSON form of ``config`` (provenance)."""
    canonical = json.dumps(config, sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.sha256(canonical.encode()).hexdigest()[:16]

"""The car as an engineer describes it: the optional vehicle quantities that only some computations
need (centre-of-gravity height, track width, steering ratio), read with an error that names the key,
and the engineering terms of the vehicle section.

The derivation of the model's internal constants from the engineering keys (mass, yaw inertia,
centre-of-gravity position, cornering stiffness in N/rad or Magic-Formula factors per axle) and
its inverse live in :mod:`uqdrive.vehicle_spec`, re-exported here: the config loader, a layer
below this package, applies them when a config is read, so that every reader of
``config["vehicle"]`` sees the internal constants.
"""

from __future__ import annotations

from typing import Any, Mapping

from ..config import ConfigError
from ..vehicle_spec import ENGINEERING_KEYS, engineering_terms, internal_constants, vehicle_names

__all__ = ["OPTIONAL_QUANTITIES", "ENGINEERING_KEYS", "require", "engineering_terms", "internal_constants", "vehicle_names"]

#: Optional keys of the config's ``vehicle`` section: key -> (unit, meaning).
OPTIONAL_QUANTITIES = {
    "cg_height": ("m", "height of the centre of gravity above the ground"),
    "track_width": ("m", "track width (lateral distance between the wheel centres of one axle)"),
    "steering_ratio": ("-", "hand-wheel angle per road-wheel angle"),
}


def require(config: Mapping[str, Any], key: str, purpose: str) -> float:
    """The optional vehicle quantity ``key`` of ``config``, or a :class:`ConfigError` naming it.

    Parameters
    ----------
    config : mapping
        A validated uqdrive config.
    key : str
        One of :data:`OPTIONAL_QUANTITIES`.
    purpose : str
        What needs it, for the message (e.g. "the effect longitudinal_load_transfer").

    Returns
    -------
    float
        The value in the unit of :data:`OPTIONAL_QUANTITIES`.
    """
    unit, meaning = OPTIONAL_QUANTITIES[key]
    value = config["vehicle"].get(key)
    if value is None:
        raise ConfigError(f"{purpose} needs config key 'vehicle.{key}' ({meaning}, {unit}), which is not given; "
                          f"add it to the vehicle section or the vehicle file")
    return float(value)

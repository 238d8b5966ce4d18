"""The car in an engineer's terms: the engineering keys of the config's ``vehicle`` section and of
vehicle files, and the single-track model's internal constants derived from them.

This module is the one place of these formulas. The models read the internal constants (thesis
Tables 5.1, 5.2 and (5.3)): ``vehicle.m_base`` (kg), ``vehicle.J0`` = I_z / m (m^2),
``vehicle.wheelbase`` L (m), ``vehicle.c_Sf`` and ``vehicle.c_Sr`` (the Magic-Formula stiffness
factor B of each axle, -), ``tyre.C`` and ``tyre.E`` (one shape and one curvature factor for both
axles) and ``uncertainty.l_f.mean`` (m). The config loader calls :func:`normalise_vehicle`, which
replaces every engineering key by its internal counterpart, so every reader of
``config["vehicle"]["J0"]`` sees the same numbers whichever form the user wrote. A config in the
internal terms passes through untouched (bit for bit).

Engineering keys (``vehicle.*``), each an alternative to the internal key it names:

============================  ==========  ============================================================
key                           unit        gives
============================  ==========  ============================================================
``mass``                      kg          m_base = mass (the car without load)
``yaw_inertia``               kg m^2      J0 = yaw_inertia / m_base (I_z at the mass without
                                          load; the model scales it with the mass, I_z = m J0)
``cg_to_front_axle``          m           uncertainty.l_f.mean = cg_to_front_axle
``front_axle_load_share``     -           uncertainty.l_f.mean = L (1 - share), share = l_r / L
``cornering_stiffness:``      N/rad       c_Sf = C_alpha,f / (F_zf,nom C), c_Sr = C_alpha,r /
                                          (F_zr,nom C) with keys ``{front, rear}``: both tyres of an
                                          axle, at mu = 1 and the static axle loads of the car
                                          without load
``magic_formula:``            -           c_Sf = front.B, c_Sr = rear.B, tyre.C = C, tyre.E = E
                                          with keys ``{front, rear}: {B, C, E}`` (D is mu); the model
                                          has one C and one E, so the two axles must give equal C
                                          and equal E
============================  ==========  ============================================================

The nominal axle loads of the cornering-stiffness form are those of the mass without load at the
centre-of-gravity position of the config (the l_f mean): F_zf,nom = m_base g l_r / L and
F_zr,nom = m_base g l_f / L with l_r = L - l_f and g = ``vehicle.g``. They follow from the slope
of the Magic Formula (2.2a) at zero slip, dF_y/dalpha = F_z B C D with D = mu = 1. A quantity
given in two forms is refused with an error naming both keys.
"""

from __future__ import annotations

import copy
from importlib.resources import files
from pathlib import Path
from typing import Any, Callable, Mapping

import yaml

from ._errors import ConfigError
from ._yaml import load_yaml

__all__ = ["OPTIONAL_QUANTITIES", "require", "ENGINEERING_KEYS", "PLAUSIBLE", "FILE_KEY_HINTS", "FILE_ONLY_KEYS", "vehicle_names", "read_vehicle_file", "internal_constants", "engineering_terms", "check_car", "check_plausible", "derived_from", "apply_vehicle_file",
           "normalise_vehicle"]

#: Engineering keys of the vehicle section: key -> (unit, meaning).
ENGINEERING_KEYS = {
    "mass": ("kg", "mass of the car without load"),
    "yaw_inertia": ("kg m^2", "yaw moment of inertia at the mass without load"),
    "cg_to_front_axle": ("m", "distance from the centre of gravity to the front axle, l_f"),
    "front_axle_load_share": ("-", "static share of the weight on the front axle, l_r / L"),
    "cornering_stiffness": ("N/rad", "cornering stiffness of each axle (front, rear; both tyres) at mu = 1 and the "
                                     "static axle load of the car without load"),
    "magic_formula": ("-", "Magic-Formula B, C, E of each axle's tyres (front, rear; D is mu)"),
}
#: Keys of a vehicle file that are no car quantities.
FILE_ONLY_KEYS = ("description", "source")
#: What each required key of a vehicle file holds, for the message when it is missing.
FILE_KEY_HINTS = {
    "description": "a line naming the car, e.g. 'description: my test car, summer tyres' (uqdrive vehicles lists it)",
    "source": "where the numbers come from, e.g. 'source: data sheet of 2024-03' or 'source: own measurement' (provenance)",
    "mass": "'mass:' the mass of the car without load in kg",
    "yaw_inertia": "'yaw_inertia:' the yaw moment of inertia in kg m^2",
    "wheelbase": "'wheelbase:' the distance between the axles in m",
}
#: Keys of the vehicle section a vehicle file leaves to the config (operating conditions).
OPERATING_KEYS = ("speed_kmh", "g", "M_c")
#: Physical range of each engineering number: key -> (low, high, unit); low exclusive, high inclusive.
_RANGES = {
    "mass": (0.0, 1e5, "kg"),
    "yaw_inertia": (0.0, 1e7, "kg m^2"),
    "cg_to_front_axle": (0.0, 20.0, "m"),
    "front_axle_load_share": (0.0, 1.0, "-"),
    "cornering_stiffness.front": (0.0, 1e7, "N/rad"),
    "cornering_stiffness.rear": (0.0, 1e7, "N/rad"),
    **{f"magic_formula.{axle}.{f}": (lo, hi, "-") for axle in ("front", "rear") for f, lo, hi in (("B", 0.0, 1e3), ("C", 0.0, 10.0))},
}
#: What a car's engineering numbers plausibly are (road vehicles from a small car to a loaded
#: truck): key -> (low, high, unit, the likely slip below, the likely slip above); a value outside
#: is refused with the slip that would explain it (a mass in tonnes, a stiffness in kN/rad).
PLAUSIBLE = {
    "mass": (100.0, 6e4, "kg", ("tonnes", 1e3), None),
    "yaw_inertia": (50.0, 1e6, "kg m^2", ("t m^2", 1e3), ("g m^2", 1e-3)),
    "wheelbase": (1.0, 12.0, "m", None, ("mm", 1e-3)),
    "cg_to_front_axle": (0.1, 10.0, "m", None, ("mm", 1e-3)),
    "cg_height": (0.1, 3.0, "m", None, ("mm", 1e-3)),
    "track_width": (0.5, 3.5, "m", None, ("mm", 1e-3)),
    "cornering_stiffness.front": (1e4, 5e6, "N/rad", ("kN/rad", 1e3), None),
    "cornering_stiffness.rear": (1e4, 5e6, "N/rad", ("kN/rad", 1e3), None),
}
#: One physical quantity per entry, with the keys that can give it (dotted, from the config root).
_FORMS = (
    ("the wheelbase", ("vehicle.wheelbase",), "m"),
    ("the mass without load", ("vehicle.mass", "vehicle.m_base"), "kg"),
    ("the yaw inertia", ("vehicle.yaw_inertia", "vehicle.J0"), "kg m^2 or, for J0 = I_z / m, m^2"),
    ("the centre-of-gravity position", ("vehicle.cg_to_front_axle", "vehicle.front_axle_load_share", "uncertainty.l_f.mean"), "m or -"),
    ("the front cornering stiffness", ("vehicle.cornering_stiffness", "vehicle.magic_formula", "vehicle.c_Sf"), "N/rad or -"),
    ("the rear cornering stiffness", ("vehicle.cornering_stiffness", "vehicle.magic_formula", "vehicle.c_Sr"), "N/rad or -"),
    ("the tyre shape factor C", ("vehicle.magic_formula", "tyre.C"), "-"),
    ("the tyre curvature factor E", ("vehicle.magic_formula", "tyre.E"), "-"),
)


def _has(cfg: Mapping, dotted: str) -> bool:
    node: Any = cfg
    for part in dotted.split("."):
        if not isinstance(node, Mapping) or part not in node:
            return False
        node = node[part]
    return True


def _get(node: Mapping, dotted: str):
    for part in dotted.split("."):
        node = node[part]
    return node


def internal_constants(vehicle: Mapping[str, Any], tyre: Mapping[str, Any], l_f: float | None = None) -> dict:
    """The model's internal constants of a vehicle section in either form.

    Parameters
    ----------
    vehicle : mapping
        The vehicle section: ``wheelbase`` (m), ``g`` (m/s^2) and each quantity in one form
        (see the module docstring): ``mass`` or ``m_base`` (kg); ``yaw_inertia`` (kg m^2) or
        ``J0`` (m^2); ``cornering_stiffness`` {front, rear} (N/rad), ``magic_formula``
        {front, rear}: {B, C, E} or ``c_Sf``, ``c_Sr`` (-); optionally ``cg_to_front_axle`` (m)
        or ``front_axle_load_share`` (-).
    tyre : mapping
        The tyre section, ``C`` and ``E`` (-), read unless ``magic_formula`` gives them.
    l_f : float, optional
        The l_f mean (m) when the vehicle section gives no centre-of-gravity position.

    Returns
    -------
    dict
        ``m_base`` (kg), ``J0`` (m^2), ``wheelbase`` (m), ``c_Sf``, ``c_Sr``, ``C``, ``E`` (-) and
        ``l_f`` (m). Given internal values are returned as given (the same floats)::

            m_base = mass,    J0 = I_z / m_base,    l_f = cg_to_front_axle  or  L (1 - share)
            B_f = C_alpha,f / (F_zf,nom C),  F_zf,nom = m_base g l_r / L     (2.2a) slope, mu = 1
            B_r = C_alpha,r / (F_zr,nom C),  F_zr,nom = m_base g l_f / L,    l_r = L - l_f
    """
    L, g = vehicle["wheelbase"], vehicle["g"]
    m_base = vehicle["mass"] if "mass" in vehicle else vehicle["m_base"]
    J0 = vehicle["yaw_inertia"] / m_base if "yaw_inertia" in vehicle else vehicle["J0"]
    if "cg_to_front_axle" in vehicle:
        l_f = vehicle["cg_to_front_axle"]
    elif "front_axle_load_share" in vehicle:
        l_f = L * (1.0 - vehicle["front_axle_load_share"])
    mf = vehicle.get("magic_formula")
    C, E = (mf["front"]["C"], mf["front"]["E"]) if mf else (tyre["C"], tyre["E"])
    if mf:
        c_Sf, c_Sr = mf["front"]["B"], mf["rear"]["B"]
    elif "cornering_stiffness" in vehicle:
        F_zf, F_zr = m_base * g * (L - l_f) / L, m_base * g * l_f / L
        c_Sf = vehicle["cornering_stiffness"]["front"] / (F_zf * C)
        c_Sr = vehicle["cornering_stiffness"]["rear"] / (F_zr * C)
    else:
        c_Sf, c_Sr = vehicle["c_Sf"], vehicle["c_Sr"]
    return {"m_base": m_base, "J0": J0, "wheelbase": L, "c_Sf": c_Sf, "c_Sr": c_Sr, "C": C, "E": E, "l_f": l_f}


def engineering_terms(config: Mapping[str, Any]) -> dict:
    """The car of a normalised config in an engineer's numbers (the inverse of
    :func:`internal_constants` at the l_f mean): mass (kg), yaw_inertia = J0 m_base (kg m^2),
    wheelbase, l_f, l_r (m), front_axle_load_share = l_r / L (-), cornering_stiffness front and rear
    = F_z,nom B C (N/rad, mu = 1, the car without load) and the Magic-Formula B_f, B_r, C, E (-)."""
    veh, tyre = config["vehicle"], config["tyre"]
    m, L, g, l_f = veh["m_base"], veh["wheelbase"], veh["g"], config["uncertainty"]["l_f"]["mean"]
    l_r = L - l_f
    return {"mass": m, "yaw_inertia": veh["J0"] * m, "wheelbase": L, "l_f": l_f, "l_r": l_r, "front_axle_load_share": l_r / L,
            "cornering_stiffness_front": m * g * l_r / L * veh["c_Sf"] * tyre["C"],
            "cornering_stiffness_rear": m * g * l_f / L * veh["c_Sr"] * tyre["C"],
            "B_f": veh["c_Sf"], "B_r": veh["c_Sr"], "C": tyre["C"], "E": tyre["E"]}


def check_car(vehicle: Mapping[str, Any], name=lambda key: f"config key 'vehicle.{key}'") -> None:
    """Physical checks of the engineering keys of ``vehicle`` (a vehicle section or file):
    ranges with units, a car's plausible numbers (:data:`PLAUSIBLE`, naming the unit slip that
    would explain a value outside them), the centre of gravity inside the wheelbase, one C and
    one E for both axles.
    ``name(key)`` names a key in the messages."""
    for key, (lo, hi, unit) in _RANGES.items():
        if not _has(vehicle, key):
            continue
        value = _get(vehicle, key)
        if not lo < value <= hi:
            raise ConfigError(f"{name(key)} = {value:g} {unit} is outside the physical range ({lo:g}, {hi:g}] {unit}; "
                              f"give {ENGINEERING_KEYS[key.split('.')[0]][1]} in {unit}")
    for key in PLAUSIBLE:
        if _has(vehicle, key):
            check_plausible(key, _get(vehicle, key), name(key))
    L, l_f, share = vehicle.get("wheelbase"), vehicle.get("cg_to_front_axle"), vehicle.get("front_axle_load_share")
    if l_f is not None and L is not None and not 0.0 < l_f < L:
        raise ConfigError(f"{name('cg_to_front_axle')} = {l_f:g} m lies outside the wheelbase: give the distance from the centre of "
                          f"gravity to the front axle in m, between 0 and the wheelbase {L:g} m")
    if share is not None and not share < 1.0:
        raise ConfigError(f"{name('front_axle_load_share')} = {share:g} puts the centre of gravity on the front axle; give the "
                          "static share of the weight on the front axle, between 0 and 1 (e.g. 0.55)")
    mf = vehicle.get("magic_formula")
    for factor in ("C", "E") if mf else ():
        if mf["front"][factor] != mf["rear"][factor]:
            raise ConfigError(f"{name(f'magic_formula.front.{factor}')} = {mf['front'][factor]:g} differs from "
                              f"{name(f'magic_formula.rear.{factor}')} = {mf['rear'][factor]:g}; the single-track model has one "
                              f"{factor} for both axles: give equal values (or the cornering stiffness in N/rad)")


def check_plausible(key: str, value: float, label: str) -> None:
    """A :class:`ConfigError` naming ``label`` when ``value`` of the quantity ``key`` of
    :data:`PLAUSIBLE` is not a car's, with the unit slip that would explain it (tonnes for kg)."""
    lo, hi, unit, below, above = PLAUSIBLE[key]
    if lo <= value <= hi:
        return
    slip = below if value < lo else above
    guess = f"; {slip[0]}? give it in {unit} ({value * slip[1]:g} {unit})" if slip and lo <= value * slip[1] <= hi else ""
    raise ConfigError(f"{label} = {value:g} {unit} is not a car's (cars: {lo:g} to {hi:g} {unit}){guess or f'; give it in {unit}'}")


def derived_from(vehicle: Mapping[str, Any]) -> dict:
    """Which engineering keys of the vehicle section (or file) ``vehicle`` give each internal
    constant: dotted config key -> the user's key(s) in words (e.g. ``vehicle.J0`` ->
    ``yaw_inertia / mass``), for messages about a derived value in the user's own terms."""
    out = {}
    if "mass" in vehicle:
        out["vehicle.m_base"] = "mass"
    if "yaw_inertia" in vehicle:
        out["vehicle.J0"] = "yaw_inertia / mass" if "mass" in vehicle else "yaw_inertia / m_base"
    for axle, key in (("front", "vehicle.c_Sf"), ("rear", "vehicle.c_Sr")):
        if "cornering_stiffness" in vehicle:
            out[key] = f"cornering_stiffness.{axle} over the static axle load and tyre C"
        elif "magic_formula" in vehicle:
            out[key] = f"magic_formula.{axle}.B"
    if "magic_formula" in vehicle:
        out.update({"tyre.C": "magic_formula C", "tyre.E": "magic_formula E"})
    for key in ("cg_to_front_axle", "front_axle_load_share"):
        if key in vehicle:
            out["uncertainty.l_f.mean"] = key
    return out


def _one_form(cfg: Mapping[str, Any]) -> None:
    for quantity, keys, unit in _FORMS:
        given = [k for k in keys if _has(cfg, k)]
        if len(given) > 1:
            raise ConfigError(f"config keys '{given[0]}' and '{given[1]}' both give {quantity}; keep one of them")
        if not given:
            raise ConfigError(f"config key '{keys[-1]}' is missing; give {quantity} ({unit}) as "
                              + " or ".join(f"'{k}'" for k in keys))


def apply_vehicle_file(config: Mapping[str, Any], spec: Mapping[str, Any], name: str) -> dict:
    """A copy of ``config`` with the car of the checked vehicle file ``spec`` (named ``name``).

    The file replaces the car: every key of the vehicle section but the operating conditions
    ``speed_kmh`` and ``g`` (and ``M_c`` unless the file gives it), the l_f mean, and tyre C and E
    when the file gives the Magic-Formula form. The l_f std and every other section stay.
    """
    cfg = copy.deepcopy(dict(config))
    kept = {k: v for k, v in cfg["vehicle"].items() if k in OPERATING_KEYS}
    cfg["vehicle"] = {**kept, **{k: copy.deepcopy(v) for k, v in spec.items() if k not in FILE_ONLY_KEYS}, "name": name}
    cfg["uncertainty"]["l_f"] = {k: v for k, v in cfg["uncertainty"]["l_f"].items() if k != "mean"}
    if "magic_formula" in spec:
        cfg["tyre"] = {k: v for k, v in cfg["tyre"].items() if k not in ("C", "E")}
    return cfg


def normalise_vehicle(config: dict) -> dict:
    """``config`` (schema-valid, a private copy) with its vehicle quantities in the internal terms.

    A config without engineering keys is returned unchanged; otherwise each quantity must be
    given in exactly one form (:data:`_FORMS`) and the engineering keys are replaced by
    :func:`internal_constants`.
    """
    veh = config["vehicle"]
    _one_form(config)
    if not any(k in veh for k in ENGINEERING_KEYS):
        return config
    check_car(veh)
    internal = internal_constants(veh, config["tyre"], config["uncertainty"]["l_f"].get("mean"))
    config["vehicle"] = {**{k: v for k, v in veh.items() if k not in ENGINEERING_KEYS},
                         **{k: internal[k] for k in ("m_base", "J0", "wheelbase", "c_Sf", "c_Sr")}}
    config["tyre"] = {**config["tyre"], "C": internal["C"], "E": internal["E"]}
    config["uncertainty"]["l_f"] = {"mean": internal["l_f"], **{k: v for k, v in config["uncertainty"]["l_f"].items() if k != "mean"}}
    return config


def vehicle_names() -> list[str]:
    """Names of the packaged vehicle files (``uqdrive/vehicles/NAME.yaml``, copies of the
    repository's ``config/vehicles``), sorted."""
    return sorted(p.name[:-5] for p in files("uqdrive").joinpath("vehicles").iterdir() if p.name.endswith(".yaml"))


def read_vehicle_file(reference: str | Path, check_schema: Callable[[dict, str], None]) -> tuple[str, dict]:
    """The name and the checked content of a vehicle file: a packaged name (:func:`vehicle_names`)
    or the path of a YAML file (ending in .yaml or .yml, holding a /, or naming an existing file).

    ``check_schema(spec, label)`` validates the content against the vehicle file schema (the
    config loader's); ``label`` formats a key for its messages. :func:`check_car` follows.

    Raises
    ------
    ConfigError
        For an unknown name, an unreadable file, or content that fails a check.
    """
    ref = str(reference)
    path = Path(ref)
    if ref.endswith((".yaml", ".yml")) or "/" in ref or path.is_file():
        name, where = path.stem, ref
        try:
            text = path.read_bytes().decode("utf-8-sig")
        except (OSError, UnicodeDecodeError) as exc:
            raise ConfigError(f"cannot read vehicle file '{ref}': {getattr(exc, 'strerror', None) or exc}; give a packaged name "
                              f"({', '.join(vehicle_names())}) or the path of a UTF-8 YAML vehicle file") from None
    elif ref in vehicle_names():
        name, where = ref, f"packaged vehicle '{ref}'"
        text = files("uqdrive").joinpath("vehicles", f"{ref}.yaml").read_text(encoding="utf-8")
    else:
        raise ConfigError(f"unknown vehicle '{ref}'; choose one of {', '.join(vehicle_names())} (uqdrive vehicles lists them) "
                          "or give the path of a vehicle file (NAME.yaml)")
    try:
        spec = load_yaml(text)
    except (yaml.YAMLError, RecursionError) as exc:
        raise ConfigError(f"vehicle file '{where}' is not valid YAML: {' '.join(str(exc).split())}") from None
    if not isinstance(spec, dict):
        raise ConfigError(f"vehicle file '{where}' must hold a mapping of keys (see config/vehicles/thesis.yaml)")
    label = f"vehicle file '{where}': key '{{}}'"
    check_schema(spec, label)
    for quantity, keys in (("the centre-of-gravity position", ("cg_to_front_axle", "front_axle_load_share")),
                           ("the cornering stiffness", ("cornering_stiffness", "magic_formula"))):
        given = [k for k in keys if k in spec]
        if len(given) != 1:
            raise ConfigError(f"vehicle file '{where}': " + (f"keys '{given[0]}' and '{given[1]}' both give {quantity}; keep one of them"
                                                             if given else f"key '{keys[0]}' is missing; give {quantity} as "
                                                             + " or ".join(f"'{k}' ({ENGINEERING_KEYS[k][0]})" for k in keys)))
    check_car(spec, label.format)
    return name, spec


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

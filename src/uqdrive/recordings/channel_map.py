"""The channel map of a recording: which logger channel holds each schema variable, in which unit,
with which sign and steering ratio; units are parsed and converted by pint, never by a table.
"""

from __future__ import annotations

import functools
import json
import math
import re
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, Mapping

import yaml

from .._yaml import load_yaml
from ..config import read_vehicle_file
from ..io import DataError

__all__ = ["SCHEMA_UNITS", "ChannelEntry", "ChannelMap", "read_channel_map", "unit_factor", "recorded_unit_factor",
           "channel_factor"]

#: SI unit of each variable a recording can give (the data schema's), and of the time axis.
SCHEMA_UNITS = {"psi": "rad", "psi_dot": "rad/s", "beta": "rad", "y": "m", "a_y": "m/s^2", "delta": "rad", "v": "m/s",
                "time": "s"}
_ENTRY_KEYS = {"channel", "units", "sign", "steering_ratio", "check_units", "time"}
# An accelerometer's "g" is standard gravity, not the gram pint reads it as.
_GRAVITY = re.compile(r"(?<![A-Za-z_])[gG](?![A-Za-z_0-9])")
# "Grad" is the German word for degree in logger exports; pint reads "grad" as the gradian and
# "Grad" as giga-radian, so the word is refused in a map and not taken as evidence from a file.
_AMBIGUOUS = re.compile(r"(?<![A-Za-z_])[Gg]rad(?![A-Za-z_0-9])")
# Spellings of loggers' unit labels that pint does not read as written.
_SPELLINGS = (("\u00b0", "deg"), ("\u00b2", "^2"), ("\u00b3", "^3"), ("\u00b5", "u"), ("\u03bc", "u"))
# Units that name an angle: a dimensionless label counts as an angle's unit only with one of them.
_ANGLES = {"radian", "degree", "gradian", "turn", "revolution", "arcminute", "arcsecond"}


@functools.lru_cache(maxsize=1)
def _registry():
    import pint

    return pint.UnitRegistry()


@functools.lru_cache(maxsize=256)
def unit_factor(units: str, target: str) -> float:
    """The factor that converts a value in ``units`` to ``target`` (both pint expressions).

    A bare ``g`` of an acceleration is standard gravity (9.80665 m/s^2). Only multiplicative
    units are accepted (a temperature's offset has no place in the schema).

    Raises
    ------
    ValueError
        If ``units`` does not parse or has another dimension than ``target``.
    """
    ureg = _registry()
    if _AMBIGUOUS.search(units):
        raise ValueError(f"'{units}' is ambiguous (the German word for degree, or the gradian); write deg or gon")
    want = ureg.Quantity(1.0, target)
    if want.dimensionality == ureg.Quantity(1.0, "m/s^2").dimensionality:
        units = _GRAVITY.sub("g_n", units)
    try:
        quantity = ureg.Quantity(1.0, units)
    except Exception as exc:  # pint's parser raises many kinds, an AssertionError for "-"
        raise ValueError(f"'{units}' is not a unit ({type(exc).__name__})") from None
    if quantity.dimensionality != want.dimensionality:
        raise ValueError(f"'{units}' has the dimension {quantity.dimensionality}, not {want.dimensionality} ({target})")
    return float(quantity.to(target).magnitude)


def _bare(label: str) -> str:
    """A unit label without the brackets a logger may put around it (``[deg/s]``, ``(km/h)``)."""
    return label.strip().strip("[]()").strip()


def recorded_unit_factor(label: str, target: str) -> float | None:
    """The factor to ``target`` of the unit a recording gives for a channel, when it says one.

    A logger's label counts as evidence only when pint reads it (after the spellings ``°``, ``²``,
    ``µ``) and it has a physical dimension or names an angle: ``""``, ``"-"``, ``"1"`` or ``"%"``
    say nothing, nor does the ambiguous ``Grad``.

    Parameters
    ----------
    label : str
        The unit as the file gives it (``"°/s"``, ``"m/s²"``, ``"[km/h]"``).
    target : str
        The schema's SI unit of the variable the channel is mapped to.

    Returns
    -------
    float or None
        SI value per recorded value, or None when the label says nothing.

    Raises
    ------
    ValueError
        If the label has a physical dimension other than ``target``'s (a channel of another quantity).
    """
    text = _bare(label)
    for old, new in _SPELLINGS:
        text = text.replace(old, new)
    if not text or _AMBIGUOUS.search(text):
        return None
    ureg = _registry()
    try:
        quantity = ureg.Quantity(1.0, _GRAVITY.sub("g_n", text))
    except Exception:  # pint's parser raises many kinds, an AssertionError for "-"
        return None
    named_angle = bool(_ANGLES & {name for name, _ in quantity.unit_items()})
    if quantity.dimensionless and not named_angle:
        return None
    want = ureg.Quantity(1.0, target)
    if quantity.dimensionality != want.dimensionality:
        raise ValueError(f"'{label}' has the dimension {quantity.dimensionality}, not {want.dimensionality} ({target})")
    return float(quantity.to(target).magnitude)


@dataclass(frozen=True)
class ChannelEntry:
    """One schema variable's source: the logger channel, its unit and the factor to SI.

    Attributes
    ----------
    variable : str
        The schema variable (``psi_dot``, ``a_y``, ``delta``, ``v``, ...) or ``time``.
    channel : str
        The channel name in the recording.
    units : str
        The recorded unit, as written in the map.
    sign : float
        +1, or -1 for an axis pointing the other way (e.g. a lateral axis to the right).
    steering_ratio : float
        Hand-wheel angle per road-wheel angle (-); 1 for a road-wheel angle and every other variable.
    factor : float
        SI value = factor x recorded value: unit conversion x sign / steering ratio.
    units_given : bool
        Whether the map gives the unit (else the schema's SI unit stands in, and a unit the
        recording states replaces it).
    check_units : bool
        Whether a unit the recording states must agree with the map's (``check_units: false``
        in the map: the map's unit wins over a file's wrong label).
    time : str
        The channel's own time vector in a MATLAB file, in the map's ``time`` unit (``""``: the
        file's time vector, or the time the signal carries).
    """

    variable: str
    channel: str
    units: str
    sign: float = 1.0
    steering_ratio: float = 1.0
    factor: float = 1.0
    units_given: bool = True
    check_units: bool = True
    time: str = ""


@dataclass(frozen=True)
class ChannelMap:
    """The whole map: one :class:`ChannelEntry` per variable, the time entry, and the text of the map.

    Attributes
    ----------
    entries : dict
        Variable -> :class:`ChannelEntry`, the measured variables, ``delta`` and ``v``.
    time : ChannelEntry
        The time column of a CSV recording, or the time vector of a MAT file (MDF files carry their own time axis).
    source : str
        Where the map came from (a file name, or "mapping").
    """

    entries: dict
    time: ChannelEntry
    source: str

    def as_json(self) -> str:
        """The map as read (channel, units, sign, steering_ratio per variable), JSON for provenance."""
        rows = {name: {k: v for k, v in asdict(e).items() if k != "variable" and (k != "time" or v)} for name, e in self.entries.items()}
        rows["time"] = {k: v for k, v in asdict(self.time).items() if k not in ("variable", "time")}
        return json.dumps(rows, sort_keys=True)


def _number(value: Any, where: str, fix: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(float(value)):
        raise DataError(f"{where} is {value!r}; {fix}")
    return float(value)


def _vehicle_ratio(vehicle: str | Path | None) -> float | None:
    if vehicle is None:
        return None
    from ..config import ConfigError

    try:
        _, spec = read_vehicle_file(vehicle)
    except ConfigError as exc:
        raise DataError(str(exc)) from None
    ratio = spec.get("steering_ratio")
    return None if ratio is None else float(ratio)


def _entry(name: str, raw: Any, source: str, vehicle_ratio: float | None) -> ChannelEntry:
    where = f"channel map '{source}': entry '{name}'"
    if not isinstance(raw, Mapping):
        raise DataError(f"{where} is {raw!r}; write it as {{channel: NAME, units: UNIT}}")
    unknown = sorted(set(raw) - _ENTRY_KEYS)
    if unknown:
        raise DataError(f"{where} has the unknown key '{unknown[0]}'; the keys are channel, units, sign, steering_ratio, "
                        "check_units, time")
    channel = raw.get("channel")
    if not isinstance(channel, str) or not channel:
        raise DataError(f"{where} has no channel name; give 'channel: NAME' as the recording names it")
    units_given = "units" in raw
    units = raw.get("units", SCHEMA_UNITS[name])
    if not isinstance(units, str):
        units = str(units)
    try:
        factor = unit_factor(units, SCHEMA_UNITS[name])
    except ValueError as exc:
        raise DataError(f"{where} (channel '{channel}'): unit {exc}; give a unit of {name}'s dimension "
                        f"(SI: {SCHEMA_UNITS[name]})") from None
    sign = _number(raw.get("sign", 1), f"{where}: sign", "give 1 or -1 (-1: the axis points the other way)")
    if sign not in (1.0, -1.0):
        raise DataError(f"{where}: sign is {sign:g}; give 1 or -1 (-1: the axis points the other way)")
    ratio = 1.0
    if name == "delta":
        given = raw.get("steering_ratio")
        if given is not None:
            ratio = _number(given, f"{where}: steering_ratio", "give the hand-wheel angle per road-wheel angle (-), e.g. 15.3")
            if ratio <= 0:
                raise DataError(f"{where}: steering_ratio is {ratio:g}; give the hand-wheel angle per road-wheel angle, > 0")
            if vehicle_ratio is not None and not math.isclose(ratio, vehicle_ratio, rel_tol=1e-9):
                raise DataError(f"{where}: steering_ratio {ratio:g} differs from the vehicle file's steering_ratio "
                                f"{vehicle_ratio:g}; keep one of them")
        elif vehicle_ratio is not None:
            ratio = vehicle_ratio
    elif "steering_ratio" in raw:
        raise DataError(f"{where}: steering_ratio belongs to the steering entry 'delta' only; remove it here")
    check = raw.get("check_units", True)
    if not isinstance(check, bool):
        raise DataError(f"{where}: check_units is {check!r}; give true (a unit the file states must agree) or false")
    own_time = raw.get("time", "")
    if name == "time" and "time" in raw:
        raise DataError(f"{where}: a time entry has no time of its own; remove its key 'time'")
    if not isinstance(own_time, str) or ("time" in raw and not own_time):
        raise DataError(f"{where}: time is {own_time!r}; give the name of the channel's own time vector in a MATLAB file")
    return ChannelEntry(name, channel, units, sign, ratio, factor * sign / ratio, units_given, check, own_time)


def channel_factor(entry: ChannelEntry, label: str, source: str) -> tuple[float, str]:
    """The factor and unit that convert one file's channel: the map's, checked against the file's label.

    Parameters
    ----------
    entry : ChannelEntry
        The map's entry for the channel.
    label : str
        The unit the recording states for it (``""`` when it states none).
    source : str
        The file, for the message.

    Returns
    -------
    factor : float
        SI value per recorded value (sign and steering ratio included).
    units : str
        The unit applied: the map's, or the file's where the map gives none.

    Raises
    ------
    uqdrive.io.DataError
        If the file's unit is of another quantity, or differs from the map's (unless
        ``check_units: false``).
    """
    where = f"{source}: channel '{entry.channel}' (mapped to {entry.variable})"
    try:
        recorded = recorded_unit_factor(label, SCHEMA_UNITS[entry.variable])
    except ValueError:
        if not entry.check_units:
            return entry.factor, entry.units
        raise DataError(f"{where} is recorded in '{label}', no unit of {entry.variable} ({SCHEMA_UNITS[entry.variable]}); "
                        f"map {entry.variable} to the channel that records it (or add check_units: false to its entry)") from None
    if recorded is None:
        return entry.factor, entry.units
    if not entry.units_given:
        return recorded * entry.sign / entry.steering_ratio, _bare(label)
    if entry.check_units and not math.isclose(recorded, unit_factor(entry.units, SCHEMA_UNITS[entry.variable]), rel_tol=1e-9):
        raise DataError(f"{where} is recorded in '{label}' as the file says, the map says '{entry.units}'; write units: "
                        f"{_bare(label)} in the map (or check_units: false if the file's label is wrong)")
    return entry.factor, entry.units


def read_channel_map(channels: str | Path | Mapping, vehicle: str | Path | None = None) -> ChannelMap:
    """Read and check a channel map (a MAP.yaml file or the same mapping).

    Parameters
    ----------
    channels : str, Path or mapping
        ``variable: {channel: NAME, units: UNIT[, sign: -1][, steering_ratio: R]}`` for any of
        psi, psi_dot, beta, y, a_y (at least one), ``delta`` and ``v`` (both required) and
        optionally ``time`` (CSV files and MAT files' time vectors; default: a column or vector named ``time`` in s).
    vehicle : str or Path, optional
        A packaged vehicle name or vehicle file whose ``steering_ratio`` applies to ``delta``
        when its entry gives none.

    Returns
    -------
    ChannelMap
        The checked entries with their conversion factors.
    """
    if isinstance(channels, Mapping):
        raw, source = dict(channels), "mapping"
    else:
        source = str(channels)
        try:
            raw = load_yaml(Path(channels).read_text(encoding="utf-8-sig"))
        except OSError as exc:
            raise DataError(f"cannot read channel map '{source}': {exc.strerror or exc}; give the path of MAP.yaml") from None
        except (yaml.YAMLError, UnicodeDecodeError) as exc:
            raise DataError(f"channel map '{source}' is not valid YAML ({' '.join(str(exc).split())[:120]}); "
                            "write one 'variable: {channel: NAME, units: UNIT}' per line") from None
    if not isinstance(raw, dict):
        raise DataError(f"channel map '{source}' must hold a mapping 'variable: {{channel: NAME, units: UNIT}}'")
    unknown = sorted(str(k) for k in raw if k not in SCHEMA_UNITS)
    if unknown:
        raise DataError(f"channel map '{source}': '{unknown[0]}' is no schema variable; map any of "
                        + ", ".join(SCHEMA_UNITS))
    for required, meaning in (("delta", "the steering angle"), ("v", "the vehicle speed")):
        if required not in raw:
            raise DataError(f"channel map '{source}' has no entry '{required}'; map {meaning}'s channel "
                            f"('{required}: {{channel: NAME, units: UNIT}}')")
    if not any(k in raw for k in ("psi", "psi_dot", "beta", "y", "a_y")):
        raise DataError(f"channel map '{source}' maps no measured channel; map at least one of psi, psi_dot, beta, y, a_y")
    ratio = _vehicle_ratio(vehicle)
    entries = {name: _entry(name, value, source, ratio) for name, value in raw.items() if name != "time"}
    time = _entry("time", raw["time"], source, None) if "time" in raw else ChannelEntry("time", "time", "s", units_given=False)
    return ChannelMap(entries, time, source)

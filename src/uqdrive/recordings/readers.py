"""Readers of one recorded run (MDF4 through asammdf, CSV :mod:`.csv_log`, MATLAB :mod:`.mat_log`):
each channel checked, converted to SI by the map's unit (checked against the file's), timed from zero.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..io import DataError
from .channel_map import ChannelEntry, ChannelMap, channel_factor
from .csv_log import cell_number, clock_seconds, read_csv_log
from .mat_log import DEFAULT_TIME_NAMES, find_signal, mat_signals, read_mat_tree

__all__ = ["Recording", "read_recording", "check_channel", "file_sha256", "MDF_SUFFIXES", "CSV_SUFFIXES", "MAT_SUFFIXES",
           "MAX_STEP_RATIO", "MAX_BRIDGED_GAP"]

MDF_SUFFIXES = (".mf4", ".mdf")
CSV_SUFFIXES = (".csv",)
MAT_SUFFIXES = (".mat",)
#: A step between two samples longer than this many times the channel's median step is missing
#: samples (loggers jitter by a few per cent; a lost frame doubles the step).
MAX_STEP_RATIO = 1.5
#: Longest run of missing samples (s) the spline bridges: frames a logger lost on a busy bus, or
#: values it marked invalid (NaN). Across a gap g the cubic's error on a response of frequency f
#: is about (2 pi f g)^4 / 384 of its amplitude: below 4e-4 at 2 Hz, the upper end of a car's yaw
#: and lateral response. Longer gaps are refused.
MAX_BRIDGED_GAP = 0.05
#: Fewest samples of a channel: a cubic spline through it needs four.
MIN_SAMPLES = 4


@dataclass(frozen=True)
class Recording:
    """One run as recorded: each mapped variable's own time axis and values, in SI units.

    Attributes
    ----------
    path : Path
        The file.
    channels : dict
        Variable -> (t, x): ndarray, shape (k,), times (s) on the recording's clock less
        ``clock_origin``, and ndarray, shape (k,), values in the schema's unit (sign and steering
        ratio applied).
    sha256 : str
        Hex digest of the file's bytes.
    clock_origin : float
        The recording's clock at its first sample (s); times are counted from it, so that a
        logger's absolute clock (seconds since 1970) keeps the precision of the sample steps.
    units : dict
        Variable -> the unit applied to its channel (the map's, or the file's where the map gives none).
    """

    path: Path
    channels: dict
    sha256: str
    clock_origin: float = 0.0
    units: dict = field(default_factory=dict)

    @property
    def start(self) -> float:
        """The latest first sample over the channels (s): every channel is defined from here."""
        return max(float(t[0]) for t, _ in self.channels.values())

    @property
    def end(self) -> float:
        """The earliest last sample over the channels (s)."""
        return min(float(t[-1]) for t, _ in self.channels.values())


def file_sha256(path: Path) -> str:
    """SHA-256 hex digest of the bytes of ``path``."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def check_channel(t: np.ndarray, x: np.ndarray, source: str, channel: str,
                  clock_origin: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """The channel's valid samples; refuse a time that does not increase, or a gap the spline cannot bridge.

    NaN or infinite values are samples the logger had no value for: dropped, like lost frames,
    and refused only where they leave a gap longer than :data:`MAX_BRIDGED_GAP` inside the record.

    Parameters
    ----------
    t : ndarray, shape (k,)
        Sample times (s).
    x : ndarray, shape (k,)
        Values (any unit).
    source, channel : str
        The file and the channel, for the message.
    clock_origin : float
        Added to the times the messages name (s): ``t`` counted from it, the file's clock.

    Returns
    -------
    t, x : ndarray, shape (m,)
        The samples with finite values, m <= k.
    """
    if not np.all(np.isfinite(t)):
        raise DataError(f"{source}: channel '{channel}' has NaN or infinite times; repair the recording's time axis")
    steps = np.diff(t)
    back = np.flatnonzero(steps <= 0)
    if back.size:
        i = int(back[0])
        raise DataError(f"{source}: channel '{channel}' has a time that does not increase at sample {i + 1} (t = "
                        f"{t[i] + clock_origin:.6g} s then {t[i + 1] + clock_origin:.6g} s); sort the samples or repair the "
                        "logger's clock")
    valid = np.isfinite(x)
    if valid.sum() < MIN_SAMPLES:
        raise DataError(f"{source}: channel '{channel}' has {int(valid.sum())} valid sample(s); give at least {MIN_SAMPLES} "
                        "(the whole run)")
    typical = float(np.median(steps))
    kept = t[valid]
    gaps = np.diff(kept)
    long = np.flatnonzero((gaps > MAX_STEP_RATIO * typical) & (gaps > MAX_BRIDGED_GAP))
    if long.size:
        i = int(long[0])
        a, b = kept[i] + clock_origin, kept[i + 1] + clock_origin
        invalid = int(np.sum(~valid[(t > kept[i]) & (t < kept[i + 1])]))
        if invalid:
            raise DataError(f"{source}: channel '{channel}' holds {invalid} NaN or infinite value(s) from t = {a:.6g} s to "
                            f"{b:.6g} s, longer than the {MAX_BRIDGED_GAP:g} s the import bridges; repair or cut those samples "
                            "from the recording")
        raise DataError(f"{source}: channel '{channel}' has a gap of {gaps[i]:.6g} s at t = {a:.6g} s (its period is "
                        f"{typical:.6g} s; the import bridges up to {MAX_BRIDGED_GAP:g} s); record the run again or cut it "
                        "before the gap")
    return kept, x[valid]


def _convert(entry: ChannelEntry, t: np.ndarray, x: np.ndarray, source: str, label: str, origin: float = 0.0) -> tuple:
    t, x = check_channel(t, x, source, entry.channel, origin)
    factor, units = channel_factor(entry, label, source)
    return t, x * factor, units


def _read_mdf(path: Path, cmap: ChannelMap) -> tuple[dict, float]:
    from asammdf import MDF

    source = str(path)
    try:
        mdf = MDF(path)
    except Exception as exc:  # asammdf raises many kinds for a file that is not MDF
        raise DataError(f"{source}: not a readable MDF file ({str(exc).splitlines()[0] if str(exc) else type(exc).__name__}); "
                        "export the run as MDF4 (.mf4) or CSV") from None
    out = {}
    try:
        for name, entry in cmap.entries.items():
            where = mdf.channels_db.get(entry.channel)
            if not where:
                raise DataError(f"{source}: channel '{entry.channel}' (mapped to {name}) is not in the file; fix the name "
                                "in the channel map or record that channel")
            group, index = where[0]
            signal = mdf.get(entry.channel, group=group, index=index)
            t = np.asarray(signal.timestamps, dtype=float)
            try:
                x = np.asarray(signal.samples, dtype=float)
            except (TypeError, ValueError):
                raise DataError(f"{source}: channel '{entry.channel}' holds no numbers ({signal.samples.dtype}); map a "
                                "numeric channel") from None
            out[name] = _convert(entry, t, x, source, str(signal.unit or ""))
    finally:
        mdf.close()
    origin = min(float(t[0]) for t, _, _ in out.values())
    return {name: (t - origin, x, units) for name, (t, x, units) in out.items()}, origin


def _numbers(cells: list, entry: ChannelEntry, decimal: str, source: str) -> np.ndarray:
    values = np.full(len(cells), np.nan)
    for i, cell in enumerate(cells):
        if not cell:
            continue  # a slower channel has no sample in this row
        try:
            values[i] = cell_number(cell, decimal)
        except ValueError:
            raise DataError(f"{source}: channel '{entry.channel}' holds '{cell}' in data row {i + 1}, not a number; "
                            f"give numbers with a decimal {'comma' if decimal == ',' else 'point'}") from None
    return values


def _read_csv(path: Path, cmap: ChannelMap) -> tuple[dict, float]:
    source = str(path)
    mapped = [("time", cmap.time), *cmap.entries.items()]
    log = read_csv_log(path, [entry.channel for _, entry in mapped])
    columns = {}
    for name, entry in mapped:
        j = log.column(entry.channel)
        if j is None:
            what = "the time column" if name == "time" else f"mapped to {name}"
            raise DataError(f"{source}: channel '{entry.channel}' ({what}) is not in the header; fix the name in the channel "
                            f"map{' (time: {channel: NAME, units: UNIT})' if name == 'time' else ''} or export that channel")
        columns[name] = (entry, [row[j] if j < len(row) else "" for row in log.body], log.units[j])
    time_entry, cells, label = columns.pop("time")
    if not all(cells):
        raise DataError(f"{source}: channel '{time_entry.channel}' (the time) is empty in data row "
                        f"{cells.index('') + 1}; give a time on every row")
    clock = clock_seconds(cells)
    if clock is None:  # numbers in the time's unit: counted from the first before scaling, for the precision
        raw = _numbers(cells, time_entry, log.decimal, source)
        factor, _ = channel_factor(time_entry, label, source)
        t_all, origin = (raw - raw[0]) * factor, float(raw[0]) * factor
    else:
        t_all, origin = clock, 0.0
    back = np.flatnonzero(np.diff(t_all) <= 0)
    if back.size:
        i = int(back[0])
        raise DataError(f"{source}: channel '{time_entry.channel}' (the time) does not increase at data row {i + 2} "
                        f"({t_all[i] + origin:.6g} s then {t_all[i + 1] + origin:.6g} s); sort the rows or repair the "
                        "logger's clock")
    out = {}
    for name, (entry, cells, label) in columns.items():
        values = _numbers(cells, entry, log.decimal, source)
        present = np.array([bool(c) for c in cells])
        out[name] = _convert(entry, t_all[present], values[present], source, label, origin)
    return out, origin


def _file_time(signals: list, cmap: ChannelMap, source: str, channel: str = ""):
    """A MAT file's time vector (s, from its first sample), its first value (s) and its signal:
    ``channel`` (an entry's own time), else the map's ``time`` channel, else a vector named as in
    :data:`~.mat_log.DEFAULT_TIME_NAMES` (None when there is none)."""
    entry = cmap.time
    if channel:
        signal = find_signal(signals, channel, source, "a channel's time")
    elif entry.units_given or entry.channel != "time":
        signal = find_signal(signals, entry.channel, source, "the time")
    else:
        named = [[s for s in signals if s.time is None and any(n.casefold() == name for n in s.names)] for name in DEFAULT_TIME_NAMES]
        signal = next((found[0] for found in named if len(found) == 1), None)
        if signal is None:
            return None
    factor, _ = channel_factor(entry, signal.unit, source)
    raw = signal.values
    return (raw - raw[0]) * factor, float(raw[0]) * factor, signal


def _read_mat(path: Path, cmap: ChannelMap) -> tuple[dict, float]:
    source = str(path)
    signals = mat_signals(read_mat_tree(path))
    found = {name: find_signal(signals, entry.channel, source, f"mapped to {name}") for name, entry in cmap.entries.items()}
    shared = None
    untimed = [entry.channel for name, entry in cmap.entries.items() if found[name].time is None and not entry.time]
    if untimed:
        shared = _file_time(signals, cmap, source)
        if shared is None:
            raise DataError(f"{source}: channel '{untimed[0]}' has no time axis of its own and the file has no vector named "
                            f"{', '.join(DEFAULT_TIME_NAMES)}; name the file's time vector in the channel map (time: {{channel: NAME, "
                            "units: s})")
    out = {}
    for name, entry in cmap.entries.items():
        signal = found[name]
        if entry.time or signal.time is None:
            t, origin, clock = _file_time(signals, cmap, source, entry.time) if entry.time else shared
            if t.size != signal.values.size:
                raise DataError(f"{source}: channel '{entry.channel}' has {signal.values.size} samples, the time "
                                f"'{clock.path}' {t.size}; give its entry the time vector recorded with it ({name}: "
                                f"{{channel: {entry.channel}, time: NAME}})")
        else:
            t, origin = signal.time, 0.0
            if t.size != signal.values.size:
                raise DataError(f"{source}: channel '{entry.channel}' has {signal.values.size} samples and its time axis "
                                f"{t.size}; repair the recording")
        out[name] = (t, origin, signal.values, signal.unit)
    # each time counted from the first sample on its own axis's origin: an absolute clock keeps its steps' precision
    origin = min(base + float(t[0]) for t, base, _, _ in out.values())
    return {name: _convert(cmap.entries[name], t + (base - origin), x, source, unit, origin)
            for name, (t, base, x, unit) in out.items()}, origin


def read_recording(path: str | Path, cmap: ChannelMap) -> Recording:
    """Read the mapped channels of one run from an MDF4 (``.mf4``/``.mdf``), CSV (``.csv``) or MATLAB
    (``.mat``, :mod:`.mat_log`) file.

    Parameters
    ----------
    path : str or Path
        The recording.
    cmap : ChannelMap
        Which channel holds which variable, in which unit.

    Returns
    -------
    Recording
        Each variable's samples in SI units, every channel checked by :func:`check_channel`.
    """
    path = Path(path)
    if not path.is_file():
        raise DataError(f"recording '{path}' does not exist or is not a file; give one file per run")
    suffix = path.suffix.lower()
    own = next((entry for entry in cmap.entries.values() if entry.time), None)
    if own is not None and suffix not in MAT_SUFFIXES:
        kind = "an MDF channel carries its own time" if suffix in MDF_SUFFIXES else "a CSV's rows share its time column"
        raise DataError(f"{path}: the map gives channel '{own.channel}' the time '{own.time}', which only MATLAB files "
                        f"use ({kind}); remove the key 'time' from its entry")
    if suffix in MDF_SUFFIXES:
        channels, origin = _read_mdf(path, cmap)
    elif suffix in CSV_SUFFIXES:
        channels, origin = _read_csv(path, cmap)
    elif suffix in MAT_SUFFIXES:
        channels, origin = _read_mat(path, cmap)
    else:
        raise DataError(f"recording '{path}' has the suffix '{path.suffix}'; give MDF4 (.mf4, .mdf), CSV (.csv) or MATLAB "
                        "(.mat) files")
    return Recording(path, {name: (t, x) for name, (t, x, _) in channels.items()}, file_sha256(path), origin,
                     {name: units for name, (_, _, units) in channels.items()})

"""Readers of one recorded run: ASAM MDF4 files (asammdf) and CSV exports (a header of channel
names, ``,`` or ``;`` between fields, a decimal point or comma); each channel checked and in SI.
"""

from __future__ import annotations

import csv
import hashlib
import io as _io
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..io import DataError
from .channel_map import ChannelEntry, ChannelMap

__all__ = ["Recording", "read_recording", "check_channel", "file_sha256", "MDF_SUFFIXES", "CSV_SUFFIXES", "MAX_STEP_RATIO"]

MDF_SUFFIXES = (".mf4", ".mdf")
CSV_SUFFIXES = (".csv",)
#: A step between two samples longer than this many times the channel's median step is a gap
#: (loggers jitter by a few per cent; a lost frame doubles the step).
MAX_STEP_RATIO = 1.5
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
        Variable -> (t, x): ndarray, shape (k,), times (s) on the recording's clock, and
        ndarray, shape (k,), values in the schema's unit (sign and steering ratio applied).
    sha256 : str
        Hex digest of the file's bytes.
    """

    path: Path
    channels: dict
    sha256: str

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


def check_channel(t: np.ndarray, x: np.ndarray, source: str, channel: str) -> None:
    """Refuse a channel with NaN or infinite values, a time that does not increase, or a gap.

    Parameters
    ----------
    t : ndarray, shape (k,)
        Sample times (s).
    x : ndarray, shape (k,)
        Values (any unit).
    source, channel : str
        The file and the channel, for the message.
    """
    if t.size < MIN_SAMPLES:
        raise DataError(f"{source}: channel '{channel}' has {t.size} sample(s); give at least {MIN_SAMPLES} (the whole run)")
    bad = ~np.isfinite(x)
    if bad.any():
        first = int(np.flatnonzero(bad)[0])
        raise DataError(f"{source}: channel '{channel}' holds {int(bad.sum())} NaN or infinite value(s), the first at "
                        f"t = {t[first]:.6g} s; repair or cut those samples from the recording")
    if not np.all(np.isfinite(t)):
        raise DataError(f"{source}: channel '{channel}' has NaN or infinite times; repair the recording's time axis")
    steps = np.diff(t)
    back = np.flatnonzero(steps <= 0)
    if back.size:
        i = int(back[0])
        raise DataError(f"{source}: channel '{channel}' has a time that does not increase at sample {i + 1} "
                        f"(t = {t[i]:.6g} s then {t[i + 1]:.6g} s); sort the samples or repair the logger's clock")
    typical = float(np.median(steps))
    long = np.flatnonzero(steps > MAX_STEP_RATIO * typical)
    if long.size:
        i = int(long[0])
        raise DataError(f"{source}: channel '{channel}' has a gap of {steps[i]:.6g} s at t = {t[i]:.6g} s (its period is "
                        f"{typical:.6g} s); record the run again or cut it before the gap")


def _convert(entry: ChannelEntry, t: np.ndarray, x: np.ndarray, source: str) -> tuple:
    check_channel(t, x, source, entry.channel)
    return t, x * entry.factor


def _read_mdf(path: Path, cmap: ChannelMap) -> dict:
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
            out[name] = _convert(entry, t, x, source)
    finally:
        mdf.close()
    return out


def _number(cell: str, decimal: str) -> float:
    return float(cell.replace(decimal, ".") if decimal == "," else cell)


def _read_csv(path: Path, cmap: ChannelMap) -> dict:
    source = str(path)
    try:
        text = path.read_bytes().decode("utf-8-sig")
    except UnicodeDecodeError:
        text = path.read_bytes().decode("latin-1")  # many logger exports are Windows-1252
    lines = text.splitlines()
    if len(lines) < 2:
        raise DataError(f"{source}: a CSV recording needs a header row of channel names and data rows")
    delimiter = ";" if lines[0].count(";") > lines[0].count(",") else ","
    rows = list(csv.reader(_io.StringIO(text), delimiter=delimiter))
    header = [h.strip() for h in rows[0]]
    body = [r for r in rows[1:] if any(c.strip() for c in r)]
    # With ';' between fields a ',' inside a number is the decimal comma.
    decimal = "," if delimiter == ";" and "," in text.partition("\n")[2] else "."
    columns = {}
    for name, entry in [("time", cmap.time), *cmap.entries.items()]:
        if entry.channel not in header:
            what = "the time column" if name == "time" else f"mapped to {name}"
            raise DataError(f"{source}: channel '{entry.channel}' ({what}) is not in the header; fix the name in the channel "
                            f"map{' (time: {channel: NAME, units: UNIT})' if name == 'time' else ''} or export that channel")
        j = header.index(entry.channel)
        values = np.full(len(body), np.nan)
        present = np.zeros(len(body), bool)
        for i, row in enumerate(body):
            cell = row[j].strip() if j < len(row) else ""
            if not cell:
                continue  # a slower channel has no sample in this row
            try:
                values[i] = _number(cell, decimal)
            except ValueError:
                raise DataError(f"{source}: channel '{entry.channel}' holds '{cell}' in data row {i + 1}, not a number; "
                                f"give numbers with a decimal {'comma' if decimal == ',' else 'point'}") from None
            present[i] = True
        columns[name] = (entry, values, present)
    time_entry, t_all, t_present = columns.pop("time")
    if not t_present.all():
        raise DataError(f"{source}: channel '{time_entry.channel}' (the time) is empty in data row "
                        f"{int(np.flatnonzero(~t_present)[0]) + 1}; give a time on every row")
    t_all = t_all * time_entry.factor
    back = np.flatnonzero(np.diff(t_all) <= 0)
    if back.size:
        i = int(back[0])
        raise DataError(f"{source}: channel '{time_entry.channel}' (the time) does not increase at data row {i + 2} "
                        f"({t_all[i]:.6g} s then {t_all[i + 1]:.6g} s); sort the rows or repair the logger's clock")
    return {name: _convert(entry, t_all[present], values[present], source) for name, (entry, values, present) in columns.items()}


def read_recording(path: str | Path, cmap: ChannelMap) -> Recording:
    """Read the mapped channels of one run from an MDF4 (``.mf4``/``.mdf``) or CSV (``.csv``) file.

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
    if suffix in MDF_SUFFIXES:
        channels = _read_mdf(path, cmap)
    elif suffix in CSV_SUFFIXES:
        channels = _read_csv(path, cmap)
    else:
        raise DataError(f"recording '{path}' has the suffix '{path.suffix}'; give MDF4 (.mf4, .mdf) or CSV (.csv) files")
    return Recording(path, channels, file_sha256(path))

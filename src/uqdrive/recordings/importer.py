"""From recorded runs to an ensemble in the data schema: read, convert, resample onto one grid,
align by the steering, cut to the span every run shares, and keep the provenance.
"""

from __future__ import annotations

import json
import math
import re
import warnings
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np
import xarray as xr

from ..io import MIN_RUNS, DataError, check_run_count, validate_ensemble
from ..vehicle.channels import CHANNEL_UNITS, CHANNELS
from .align import manoeuvre_window, steering_deviation, steering_offset
from .channel_map import ChannelMap, read_channel_map
from .readers import Recording, read_recording
from .resample import channel_period, continuous_channel, default_step

__all__ = ["ALIGNMENTS", "SPEED_TOLERANCE", "NOISE_MULTIPLE", "DEVIATION_FLOOR", "import_runs", "import_recordings"]

ALIGNMENTS = ("steering", "none")
#: Speeds that differ by less than this fraction are one speed (a logger's float rounding).
SPEED_TOLERANCE = 1e-6
#: A run's steering differs from the ensemble's when its deviation exceeds this many times the
#: steering's noise (the difference of two noisy copies has sqrt(2) the noise; 3 sigma beyond that).
NOISE_MULTIPLE = 3.0 * math.sqrt(2.0)
#: Smallest deviation (fraction of the steering's RMS) reported as different: a steering robot
#: repeats its path to about 0.1 %, and noise-free logs must not flag the last bits of resampling.
DEVIATION_FLOOR = 1e-3


def _step(recordings: Sequence[Recording], dt: float | None) -> float:
    if dt is not None:
        if not (math.isfinite(dt) and dt > 0):
            raise DataError(f"--dt {dt!r}: give the grid step in s, a positive number (e.g. 0.01)")
        return float(dt)
    return default_step(channel_period(t) for rec in recordings for t, _ in rec.channels.values())


def _warn_upsampled(recordings, cmap: ChannelMap, step: float) -> None:
    """Say when a measured channel is coarser than the grid: its noise is interpolated between its
    samples, smooth where white noise is not, and identify's noise estimate (differences of the
    grid's neighbours) misses it, so the fit reads the noise as a misfit."""
    coarse = {}
    for name, entry in cmap.entries.items():
        if name in CHANNELS:
            period = max(channel_period(rec.channels[name][0]) for rec in recordings)
            if period > step * (1.0 + 1e-6):
                coarse[entry.channel] = period
    if coarse:
        slowest = max(coarse.values())
        warnings.warn(f"channel(s) {', '.join(f'{c} ({p:.4g} s)' for c, p in coarse.items())} are sampled more coarsely than "
                      f"the grid ({step:.4g} s): their noise is interpolated, which the identification's noise estimate does "
                      f"not see; for identify and discover pass --dt {slowest:.4g}", UserWarning, stacklevel=3)


def _offsets(recordings, splines, cmap: ChannelMap, dt: float, align: str):
    """Offsets (s, each run's clock minus the reference's) and the manoeuvre window of the reference."""
    ref = recordings[0]
    t_ref = np.arange(ref.start, ref.end, dt)
    s_ref = splines[0]["delta"](t_ref)
    if align == "steering" and not np.any(s_ref):
        raise DataError(f"{ref.path}: channel '{cmap.entries['delta'].channel}' (the steering) never moves, so the runs "
                        "cannot be aligned by it; record the manoeuvre's steering or pass --align none")
    window = manoeuvre_window(t_ref, s_ref)
    if align == "none":
        return np.array([rec.start - ref.start for rec in recordings]), window
    offsets = [0.0]
    for rec, spl in zip(recordings[1:], splines[1:]):
        offsets.append(steering_offset(splines[0]["delta"], window, spl["delta"], (rec.start, rec.end), dt))
    return np.array(offsets), window


def _check_coverage(recordings, cmap: ChannelMap, offsets, window, align: str) -> tuple[float, float]:
    """The shared span on the reference's clock; a run that misses part of the manoeuvre is refused."""
    steer = cmap.entries["delta"].channel
    for rec, o in zip(recordings, offsets):
        start, end = rec.start - o, rec.end - o
        if align == "none":
            continue
        if start >= window[0]:  # not one sample of straight driving before the steering departs
            raise DataError(f"{rec.path}: channel '{steer}' starts {start - window[0]:.3g} s after the manoeuvre's steering "
                            f"begins (the steering is already turned at its first sample or the other runs show it); record "
                            f"from before the manoeuvre or leave the file out")
        if end < window[1] - 1e-9:
            raise DataError(f"{rec.path}: channel '{steer}' ends {window[1] - end:.3g} s before the manoeuvre's steering "
                            f"does (as the other runs show); record the whole manoeuvre or leave the file out")
    return max(r.start - o for r, o in zip(recordings, offsets)), min(r.end - o for r, o in zip(recordings, offsets))


def _speed(v: np.ndarray):
    """The speed as the schema holds it: (None, v_c) when constant, else (v over time or (sample, time), None)."""
    mean = float(np.mean(v))
    if np.ptp(v) <= SPEED_TOLERANCE * abs(mean):
        return None, mean
    if np.all(np.ptp(v, axis=0) <= SPEED_TOLERANCE * np.abs(np.mean(v, axis=0))):
        return (("time",), np.mean(v, axis=0)), None
    return (("sample", "time"), v), None


def import_recordings(recordings: Sequence[Recording], cmap: ChannelMap, dt: float | None = None, align: str = "steering",
                      max_steer_deviation: float | None = None, split: dict | None = None) -> xr.Dataset:
    """The ensemble of read recordings (see :func:`import_runs`, which reads them first; ``split``:
    how they were cut out of longer ones, kept as the attribute ``import_split``)."""
    if align not in ALIGNMENTS:
        raise DataError(f"--align '{align}': choose one of {', '.join(ALIGNMENTS)}")
    if max_steer_deviation is not None and not (math.isfinite(max_steer_deviation) and max_steer_deviation > 0):
        raise DataError(f"--max-steer-deviation {max_steer_deviation!r}: give a positive fraction of the steering's RMS "
                        "(e.g. 0.05)")
    check_run_count(len(recordings), "import", "an ensemble for identify and discover")
    step = _step(recordings, dt)
    _warn_upsampled(recordings, cmap, step)
    splines = [{name: continuous_channel(t, x, step) for name, (t, x) in rec.channels.items()} for rec in recordings]
    offsets, window = _offsets(recordings, splines, cmap, step, align)
    t0, t1 = _check_coverage(recordings, cmap, offsets, window, align)
    n_time = int(math.floor((t1 - t0) / step + 1e-9)) + 1
    if n_time < 3:
        raise DataError(f"{recordings[0].path}: the runs share only {max(t1 - t0, 0.0):.3g} s; the recordings do not overlap "
                        "in time: check the files belong to one manoeuvre")
    grid = t0 + step * np.arange(n_time)
    values = {name: np.stack([spl[name](grid + o) for spl, o in zip(splines, offsets)]) for name in cmap.entries}
    deviation, noise = steering_deviation(values["delta"])
    flagged = deviation > max(NOISE_MULTIPLE * float(np.median(noise)), DEVIATION_FLOOR)
    keep = np.ones(len(recordings), bool) if max_steer_deviation is None else deviation <= max_steer_deviation
    dropped = [str(recordings[i].path) for i in np.flatnonzero(~keep)]
    if dropped:
        check_run_count(int(keep.sum()), f"import (after dropping {len(dropped)} run(s) whose steering deviates by more "
                        f"than {max_steer_deviation:g})", "an ensemble for identify and discover")
    kept = [r for r, k in zip(recordings, keep) if k]
    time = step * np.arange(n_time)
    # on the files' own clocks (each recording was read with its times counted from its first sample)
    clock_offsets = offsets + np.array([r.clock_origin for r in recordings]) - recordings[0].clock_origin
    data = {name: (("sample", "time"), values[name][keep], {"units": CHANNEL_UNITS[name]}) for name in CHANNELS if name in values}
    data["delta"] = ("time", values["delta"][keep].mean(axis=0), {"units": "rad", "interpolation": "linear",
                                                                   "description": "mean over the runs of the aligned steering"})
    speed, v_c = _speed(values["v"][keep])
    if speed is not None:
        data["v"] = (*speed, {"units": "m/s"})
    data["offset"] = ("sample", clock_offsets[keep], {"units": "s", "description": "the run's clock minus the reference run's "
                                                                               "(the first file) at the same instant"})
    data["steer_deviation"] = ("sample", deviation[keep], {"units": "1", "description": "RMS of the run's steering minus the "
                                                           "ensemble's median over the RMS of that median"})
    data["source_file"] = ("sample", np.array([str(r.path) for r in kept], dtype=object))
    data["source_sha256"] = ("sample", np.array([r.sha256 for r in kept], dtype=object))
    attrs = {
        "source": "uqdrive import of recorded runs",
        "import_files": json.dumps([{"file": str(r.path), "sha256": r.sha256} for r in recordings]),
        "import_channel_map": cmap.as_json(),
        "import_dt": step,
        "import_align": align,
        "import_reference": str(recordings[0].path),
        "import_manoeuvre_window": json.dumps([window[0] - t0, window[1] - t0]),
        "import_offsets": json.dumps({str(r.path): float(o) for r, o in zip(recordings, clock_offsets)}),
        "import_units": json.dumps({str(r.path): r.units for r in recordings}),
        "import_steer_deviation": json.dumps({str(r.path): float(d) for r, d in zip(recordings, deviation)}),
        "import_steer_noise": float(np.median(noise)),
        "import_steer_flagged": json.dumps([str(recordings[i].path) for i in np.flatnonzero(flagged)]),
        "import_dropped": json.dumps(dropped),
    }
    if split is not None:
        attrs["import_split"] = json.dumps(split)
    if v_c is not None:
        attrs["v_c"] = v_c
    ds = xr.Dataset(data, coords={"time": ("time", time, {"units": "s"}), "sample": ("sample", np.arange(len(kept)))},
                    attrs=attrs)
    try:
        return validate_ensemble(ds, "the imported ensemble")
    except DataError as exc:  # a value beyond the physical: name the channel and its map entry
        name = re.search(r"variable '(\w+)'", str(exc))
        entry = cmap.entries.get(name.group(1)) if name else None
        if entry is None:
            raise
        raise DataError(f"{exc} (channel '{entry.channel}' in {entry.units}, map '{cmap.source}': check its units, sign and "
                        f"steering_ratio)") from None


def import_runs(run_files: Sequence[str | Path], channels: str | Path | Mapping, *, vehicle: str | Path | None = None,
                dt: float | None = None, align: str = "steering", max_steer_deviation: float | None = None,
                split: float | None = None) -> xr.Dataset:
    """Import recorded runs (one MDF4, CSV or MATLAB file each) into an ensemble of the data schema.

    Parameters
    ----------
    run_files : sequence of str or Path
        One file per run: ``.mf4``/``.mdf`` (ASAM MDF, read by asammdf) or ``.csv`` (a header row
        of channel names, ``,``, ``;`` or tab between fields, a decimal point or comma; an empty
        cell is a slower channel's missing sample; :mod:`uqdrive.recordings.csv_log`) or ``.mat``
        (MATLAB v4-v7.3 in the layouts of :mod:`uqdrive.recordings.mat_log`). Units the
        files state serve where the map gives none and must agree where it does
        (:func:`uqdrive.recordings.channel_map.channel_factor`). At least :data:`uqdrive.io.MIN_RUNS`.
    channels : str, Path or mapping
        The channel map, MAP.yaml or its mapping (:func:`uqdrive.recordings.channel_map.read_channel_map`).
    vehicle : str or Path, optional
        A packaged vehicle name or vehicle file; its ``steering_ratio`` converts a hand-wheel
        steering channel whose map entry gives none.
    dt : float, optional
        Step of the output grid (s); default the period of the fastest mapped channel. Channels
        sampled faster are low-passed first (:func:`uqdrive.recordings.resample.anti_alias`).
    align : {"steering", "none"}
        ``steering``: shift each run so that its steering matches the first file's
        (:func:`uqdrive.recordings.align.steering_offset`); ``none``: take the clocks as they are.
    max_steer_deviation : float, optional
        Drop the runs whose steering deviates from the ensemble's median by more than this
        fraction of its RMS (default: keep every run, report the deviations).
    split : float, optional
        Each file may hold several runs: cut them apart where the steering rests for at least this
        long (s) (:func:`uqdrive.recordings.split.split_recordings`; a run is named ``FILE#i``,
        runs whose steering lasts other than the median run's are left out). Default: one run a file.

    Returns
    -------
    xarray.Dataset
        The validated ensemble on the span every run shares (time from 0), with ``offset`` and
        ``steer_deviation`` per run, ``source_file``/``source_sha256`` and ``import_*``
        attributes (files and hashes, the map, offsets, deviations, flagged and dropped runs).

    Raises
    ------
    uqdrive.io.DataError
        One line naming the file, the channel and the fix: a missing channel, a unit of the wrong
        dimension, a run that misses part of the manoeuvre, a channel with gaps or NaN, a time
        that does not increase, fewer runs than :data:`uqdrive.io.MIN_RUNS`.
    """
    cmap = read_channel_map(channels, vehicle)
    files = [Path(f) for f in run_files]
    if len(files) < MIN_RUNS and split is None:
        check_run_count(len(files), "import", "an ensemble for identify and discover")
    if len(set(map(str, files))) < len(files):
        twice = next(str(f) for f in files if files.count(f) > 1)
        raise DataError(f"recording '{twice}' is given twice; give each run's file once")
    recordings = [read_recording(f, cmap) for f in files]
    if split is None:
        return import_recordings(recordings, cmap, dt, align, max_steer_deviation)
    from .split import split_recordings

    runs, skipped = split_recordings(recordings, split)
    spans = {str(r.path): [r.start + r.clock_origin, r.end + r.clock_origin] for r in runs}  # every channel defined
    return import_recordings(runs, cmap, dt, align, max_steer_deviation, {"rest_s": split, "runs": spans, "skipped": skipped})

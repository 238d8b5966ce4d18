"""Recordings that hold several runs: a logger left running through a test session records the
manoeuvres one after another with straight driving between; they are cut apart where the steering rests.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from ..io import DataError
from .readers import MIN_SAMPLES, Recording

__all__ = ["DURATION_TOLERANCE", "ACTIVITY_FRACTION", "NOISE_MULTIPLE", "steering_activity", "manoeuvres", "split_recording",
           "split_recordings"]

#: A run's steering may be active this fraction longer or shorter than the median run's; a longer
#: or shorter one (a turn-around at the end of the track, a lane change) is not the manoeuvre.
DURATION_TOLERANCE = 0.25
#: The steering is active where it leaves its rest by more than this fraction of its largest
#: excursion (and by more than :data:`NOISE_MULTIPLE` times its noise).
ACTIVITY_FRACTION = 0.02
#: Multiple of the steering's noise (from its sample-to-sample differences) an active sample exceeds.
NOISE_MULTIPLE = 4.0


def steering_activity(delta: np.ndarray) -> np.ndarray:
    """Where the steering leaves its rest: straight ahead, the median of the quarter of its samples
    nearest zero (a step-steer session may hold the wheel turned for most of its time, and a
    steering sensor's zero may be off by a little).

    Parameters
    ----------
    delta : ndarray, shape (k,)
        The steering channel (rad).

    Returns
    -------
    ndarray of bool, shape (k,)
        True where |delta - rest| exceeds the larger of :data:`ACTIVITY_FRACTION` of its largest
        value and :data:`NOISE_MULTIPLE` times the noise (1.4826 MAD of the differences / sqrt(2)).
    """
    magnitude = np.abs(delta)
    rest = np.median(delta[magnitude <= np.quantile(magnitude, 0.25)])
    excursion = np.abs(delta - rest)
    noise = 1.4826 * float(np.median(np.abs(np.diff(delta)))) / math.sqrt(2.0)
    return excursion > max(ACTIVITY_FRACTION * float(excursion.max()), NOISE_MULTIPLE * noise)


def manoeuvres(t: np.ndarray, delta: np.ndarray, rest: float) -> list[tuple[float, float]]:
    """The steering's manoeuvres: its active spans, joined where it rests for less than ``rest``.

    Parameters
    ----------
    t : ndarray, shape (k,)
        Sample times (s).
    delta : ndarray, shape (k,)
        The steering (rad).
    rest : float
        Shortest rest (s) between two manoeuvres; a shorter one (a slalom's zero crossing) lies within one.

    Returns
    -------
    list of (float, float)
        First and last active time (s) of each manoeuvre, in order.
    """
    active = np.flatnonzero(steering_activity(delta))
    if active.size == 0:
        return []
    breaks = np.flatnonzero(np.diff(t[active]) >= rest)
    firsts = np.r_[active[0], active[breaks + 1]]
    lasts = np.r_[active[breaks], active[-1]]
    return [(float(t[a]), float(t[b])) for a, b in zip(firsts, lasts)]


def split_recording(rec: Recording, rest: float) -> list[tuple[Recording, float]]:
    """The runs of one recording, cut at the middle of each rest between its manoeuvres.

    Parameters
    ----------
    rec : Recording
        A recording with a ``delta`` channel.
    rest : float
        Shortest rest (s) between runs (:func:`manoeuvres`).

    Returns
    -------
    list of (Recording, float)
        Each run (its path the file's with ``#i``, i from 1; the times on the file's clock) and
        how long its steering is active (s).
    """
    t, delta = rec.channels["delta"]
    spans = manoeuvres(t, delta, rest)
    if not spans:
        raise DataError(f"{rec.path}: the steering never leaves its rest, so the file holds no run to cut out; record the "
                        "manoeuvres' steering or import without --split")
    cuts = [-math.inf] + [(b + a) / 2.0 for (_, b), (a, _) in zip(spans[:-1], spans[1:])] + [math.inf]
    runs = []
    for i, ((a, b), lo, hi) in enumerate(zip(spans, cuts[:-1], cuts[1:])):
        channels = {name: (tc[(tc >= lo) & (tc < hi)], x[(tc >= lo) & (tc < hi)]) for name, (tc, x) in rec.channels.items()}
        short = [name for name, (tc, _) in channels.items() if tc.size < MIN_SAMPLES]
        if short:
            raise DataError(f"{rec.path}: run {i + 1} (steering from t = {a + rec.clock_origin:.6g} s) holds fewer than "
                            f"{MIN_SAMPLES} samples of {short[0]}; give --split the rest that separates whole runs (s)")
        runs.append((replace(rec, path=rec.path.with_name(f"{rec.path.name}#{i + 1}"), channels=channels), b - a))
    return runs


def split_recordings(recordings, rest: float) -> tuple[list[Recording], dict]:
    """Every run of every recording, those whose steering lasts like the median run's (within
    :data:`DURATION_TOLERANCE`) kept.

    Parameters
    ----------
    recordings : sequence of Recording
    rest : float
        Shortest rest (s) between runs.

    Returns
    -------
    kept : list of Recording
        The runs, in file order.
    skipped : dict
        Path of each run left out -> why.
    """
    if not (math.isfinite(rest) and rest > 0):
        raise DataError(f"--split {rest!r}: give the shortest rest between runs in s, a positive number (e.g. 2)")
    runs = [run for rec in recordings for run in split_recording(rec, rest)]
    typical = float(np.median([active for _, active in runs]))
    kept, skipped = [], {}
    for run, active in runs:
        if abs(active - typical) <= DURATION_TOLERANCE * typical:
            kept.append(run)
        else:
            skipped[str(run.path)] = (f"steers for {active:.3g} s, the runs' median {typical:.3g} s: not the manoeuvre "
                                      f"(a turn-around, a lane change?)")
    return kept, skipped

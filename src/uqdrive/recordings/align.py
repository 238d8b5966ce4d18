"""Alignment of recorded runs by their steering: each run's time offset against a reference run by
cross-correlation (to a sample) refined to a fraction of a sample, and each run's steering deviation.
"""

from __future__ import annotations

from typing import Callable

import numpy as np
from scipy.optimize import minimize_scalar
from scipy.signal import correlate

__all__ = ["ACTIVE_FRACTION", "manoeuvre_window", "steering_offset", "steering_deviation"]

#: The steering departs from straight (or from its final value) when it differs by more than this
#: fraction of its largest angle: above a robot's noise and a sensor's zero offset, below any manoeuvre.
ACTIVE_FRACTION = 0.05


def manoeuvre_window(t: np.ndarray, s: np.ndarray) -> tuple[float, float]:
    """The part of a run where its steering acts: from its first departure from straight ahead to
    the last time it differs from its final value (a step steer may hold its angle to the end).

    Parameters
    ----------
    t : ndarray, shape (k,)
        Uniform times (s).
    s : ndarray, shape (k,)
        Steering angle (rad) at ``t``, zero straight ahead.

    Returns
    -------
    (float, float)
        Start and end (s); the whole of ``t`` for a steering that never departs. A start at t[0]
        means the recording began after the steering did.
    """
    span = float(np.max(np.abs(s)))
    if span == 0.0:
        return float(t[0]), float(t[-1])
    k = max(1, min(10, s.size // 10))
    first = np.flatnonzero(np.abs(s) > ACTIVE_FRACTION * span)
    last = np.flatnonzero(np.abs(s - np.mean(s[-k:])) > ACTIVE_FRACTION * span)
    return float(t[first[0]]), float(t[last[-1]] if last.size else t[-1])


def _samples(f: Callable, t: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """``f`` at ``t``, zero outside [lo, hi] (a run's steering is unknown there: no evidence)."""
    inside = (t >= lo) & (t <= hi)
    out = np.zeros(t.shape)
    out[inside] = f(t[inside])
    return out


def steering_offset(reference: Callable, window: tuple[float, float], run: Callable, run_span: tuple[float, float],
                    dt: float) -> float:
    """The time offset o of a run against the reference: run(t + o) ~ reference(t) over ``window``.

    The least-squares match sum_i (run(t_i + o) - ref(t_i))^2 over the window's grid t_i is
    first minimised over whole steps o = k dt by a full cross-correlation (the run is zero
    outside its recording, so a run that misses part of the manoeuvre still lands where it
    matches), then over o in [o_k - dt, o_k + dt] by Brent's bounded method on the run's
    cubic spline: a fraction of a sample, limited by the steering's noise.

    Parameters
    ----------
    reference : callable
        The reference run's steering (rad) as a function of its time (s).
    window : (float, float)
        Times (s, on the reference's clock) of the manoeuvre to match.
    run : callable
        The run's steering (rad) as a function of its time (s).
    run_span : (float, float)
        First and last time (s) of the run's recording.
    dt : float
        Step (s) of the matching grid.

    Returns
    -------
    float
        The offset o (s): the manoeuvre's instant t on the reference's clock is t + o on the run's.
    """
    tw = np.arange(window[0], window[1] + 0.5 * dt, dt)
    r = reference(tw)
    n = tw.size
    # the run on a grid with n steps of zeros either side: every partial overlap is a candidate
    tg = run_span[0] - n * dt + dt * np.arange(int(np.floor((run_span[1] - run_span[0]) / dt)) + 2 * n + 1)
    u = _samples(run, tg, *run_span)
    c = correlate(u, r, mode="valid", method="fft")
    energy = np.convolve(u * u, np.ones(n), mode="valid")
    k = int(np.argmin(energy - 2.0 * c))
    coarse = tg[k] - tw[0]

    def misfit(o: float) -> float:
        return float(np.sum((_samples(run, tw + o, *run_span) - r) ** 2))

    fine = minimize_scalar(misfit, bounds=(coarse - dt, coarse + dt), method="bounded", options={"xatol": 1e-6 * dt})
    return float(fine.x) if fine.fun <= misfit(coarse) else coarse


def steering_deviation(steering: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """How far each run's steering lies from the ensemble's, against the steering's own noise.

    Parameters
    ----------
    steering : ndarray, shape (n, T)
        The aligned steering (rad) of n runs on one grid.

    Returns
    -------
    deviation : ndarray, shape (n,)
        RMS over time of (s_i - median over runs) divided by the RMS of that median (-).
    noise : ndarray, shape (n,)
        Each run's white-noise std (from differences of order 4, which cancel the smooth steering:
        Var(d_4) = 70 sigma^2) over the same RMS (-): a robot's run deviates by about its noise.
    """
    median = np.median(steering, axis=0)
    scale = float(np.sqrt(np.mean(median**2))) or 1.0
    deviation = np.sqrt(np.mean((steering - median) ** 2, axis=1)) / scale
    d4 = np.diff(steering, n=4, axis=1)
    mad = np.median(np.abs(d4 - np.median(d4, axis=1, keepdims=True)), axis=1) / 0.6744897501960817
    return deviation, mad / np.sqrt(70.0) / scale

"""Resampling of recorded channels onto one uniform time grid: a zero-phase anti-aliasing low-pass
where a channel is decimated, then a cubic spline through the samples, evaluated on the grid.
"""

from __future__ import annotations

import numpy as np
from scipy.interpolate import CubicSpline
from scipy.signal import butter, sosfiltfilt

__all__ = ["ANTI_ALIAS_ORDER", "ANTI_ALIAS_FRACTION", "channel_period", "default_step", "anti_alias", "continuous_channel"]

#: Order of the Butterworth anti-aliasing filter (applied forwards and backwards: twice the order,
#: no phase shift, so that the decimated channels stay aligned with the others).
ANTI_ALIAS_ORDER = 8
#: Cut-off of that filter as a fraction of the grid's Nyquist frequency 1 / (2 dt): at 0.8 the
#: squared gain is 1 - (f / f_c)^16 to first order, below 1e-9 off for f < f_c / 4 (vehicle
#: responses on a 20 Hz grid: under 2 Hz), while what lies above the grid's Nyquist is removed.
ANTI_ALIAS_FRACTION = 0.8


def channel_period(t: np.ndarray) -> float:
    """The sampling period of a channel, the median step of its times.

    Parameters
    ----------
    t : ndarray, shape (k,)
        Increasing sample times (s).

    Returns
    -------
    float
        The median of t[i+1] - t[i] (s), robust to a logger's jitter.
    """
    return float(np.median(np.diff(t)))


def default_step(periods) -> float:
    """The grid step when none is given: the fastest channel's period (s), to 1e-9 s."""
    return float(np.round(min(periods), 9))


def anti_alias(x: np.ndarray, period: float, dt: float) -> np.ndarray:
    """Low-pass a channel sampled every ``period`` before it is resampled every ``dt > period``.

    Zero-phase Butterworth of order :data:`ANTI_ALIAS_ORDER` (forwards and backwards, scipy's
    ``sosfiltfilt``) with the cut-off f_c = :data:`ANTI_ALIAS_FRACTION` / (2 dt): the content the
    coarser grid cannot hold (above its Nyquist frequency) is removed instead of folded back.

    Parameters
    ----------
    x : ndarray, shape (k,)
        The channel's samples (any unit), uniformly spaced.
    period : float
        The channel's sampling period (s).
    dt : float
        The target grid's step (s), larger than ``period``.

    Returns
    -------
    ndarray, shape (k,)
        The filtered samples, in the unit of ``x``.
    """
    wn = ANTI_ALIAS_FRACTION * period / dt  # f_c over the channel's own Nyquist frequency 1 / (2 period)
    sos = butter(ANTI_ALIAS_ORDER // 2, wn, output="sos")
    padlen = min(3 * (2 * len(sos) + 1), x.size - 1)
    return sosfiltfilt(sos, x, padlen=padlen)


def continuous_channel(t: np.ndarray, x: np.ndarray, dt: float) -> CubicSpline:
    """A channel as a function of time for a grid of step ``dt``: anti-aliased if decimated.

    Parameters
    ----------
    t : ndarray, shape (k,)
        Increasing sample times (s), without gaps.
    x : ndarray, shape (k,)
        Samples (any unit).
    dt : float
        The step of the grid it will be evaluated on (s).

    Returns
    -------
    scipy.interpolate.CubicSpline
        The not-a-knot cubic spline through the (filtered) samples; its interpolation error of a
        smooth signal is O(h^4 x'''') (h the channel's period), below the sensors' noise at the
        rates of vehicle dynamics loggers (20 Hz and faster).
    """
    period = channel_period(t)
    if period < dt * (1.0 - 1e-6):
        x = anti_alias(x, period, dt)
    return CubicSpline(t, x)

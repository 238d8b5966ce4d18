"""Steering manoeuvres of the hidden-effect benchmark: each a pure function of a time grid.

Every function takes the time t (s) and an amplitude in degrees and returns the commanded front
steering angle in radians. Before the manoeuvre starts the command is zero (straight driving),
except for the slalom, which starts at its extreme like the thesis' input (5.5).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

__all__ = ["MANOEUVRES", "chirp", "double_lane_change", "slalom", "steering_command", "step_steer"]


def slalom(t, amplitude_deg: float = 5.0, period: float = 4.0, sign: float = 1.0, phase: float = 0.0):
    """Slalom sign * A cos(2 pi t / period + phase); the thesis' (5.5) is A = 5 deg, period 4 s,
    sign +1, phase 0, and (5.7) is sign -1.

    Parameters
    ----------
    t : array_like
        Time (s).
    amplitude_deg : float
        Amplitude A (deg).
    period : float
        Period (s).
    sign : float
        +1 or -1.
    phase : float
        Phase offset (rad).

    Returns
    -------
    ndarray
        Steering angle (rad).
    """
    t = np.asarray(t, dtype=float)
    return sign * np.deg2rad(amplitude_deg) * np.cos(2.0 * np.pi * t / period + phase)


def step_steer(t, amplitude_deg: float = 2.0, t_start: float = 1.0, ramp: float = 0.4, sign: float = 1.0):
    """Step steer with a smooth ramp: 0 before ``t_start``, a C1 cosine ramp over ``ramp`` s,
    then the constant sign * A.

    Returns
    -------
    ndarray
        Steering angle (rad).
    """
    t = np.asarray(t, dtype=float)
    s = np.clip((t - t_start) / ramp, 0.0, 1.0)
    return sign * np.deg2rad(amplitude_deg) * 0.5 * (1.0 - np.cos(np.pi * s))


def chirp(t, amplitude_deg: float = 2.0, f0: float = 0.1, f1: float = 1.5, duration: float = 10.0, sign: float = 1.0):
    """Linear frequency sweep sign * A sin(2 pi (f0 t + (f1 - f0) t^2 / (2 duration))) from f0 to
    f1 (Hz) over ``duration`` s; the command starts at zero.

    Returns
    -------
    ndarray
        Steering angle (rad).
    """
    t = np.asarray(t, dtype=float)
    phase = 2.0 * np.pi * (f0 * t + 0.5 * (f1 - f0) * t**2 / duration)
    return sign * np.deg2rad(amplitude_deg) * np.sin(phase)


def double_lane_change(t, amplitude_deg: float = 2.0, t_start: float = 1.0, duration: float = 2.5, hold: float = 1.5, sign: float = 1.0):
    """Double lane change: one full sine period of steering moves the car to the next lane
    (from ``t_start`` over ``duration`` s), the car drives straight for ``hold`` s, and the
    mirrored sine brings it back; zero elsewhere (continuous command).

    Returns
    -------
    ndarray
        Steering angle (rad).
    """
    t = np.asarray(t, dtype=float)
    a = np.deg2rad(amplitude_deg)
    out = np.zeros_like(t)
    for start, s in ((t_start, 1.0), (t_start + duration + hold, -1.0)):
        inside = (t >= start) & (t <= start + duration)
        out = np.where(inside, s * a * np.sin(2.0 * np.pi * (t - start) / duration), out)
    return sign * out


def pulse(t, amplitude_deg: float = 2.0, t_start: float = 1.0, width: float = 0.5, sign: float = 1.0):
    """Rectangular pulse: sign * A on [t_start, t_start + width), 0 elsewhere (a command that
    jumps; on a grid it is held between samples, the data's ``interpolation: previous``).

    Returns
    -------
    ndarray
        Steering angle (rad).
    """
    t = np.asarray(t, dtype=float)
    on = (t >= t_start - 1e-9) & (t < t_start + width - 1e-9)
    return sign * np.deg2rad(amplitude_deg) * on.astype(float)


#: Manoeuvre name -> function(t, **params) returning the steering angle (rad).
MANOEUVRES: dict[str, Callable[..., np.ndarray]] = {
    "slalom": slalom,
    "step": step_steer,
    "chirp": chirp,
    "lane_change": double_lane_change,
    "pulse": pulse,
}


def steering_command(manoeuvre: str, t, params: Mapping[str, Any] | None = None) -> np.ndarray:
    """Commanded steering angle (rad) of the named manoeuvre on the times ``t`` (s)."""
    if manoeuvre not in MANOEUVRES:
        raise ValueError(f"unknown manoeuvre '{manoeuvre}'; choose one of {', '.join(MANOEUVRES)}")
    return MANOEUVRES[manoeuvre](t, **dict(params or {}))

"""Steering manoeuvres of the hidden-effect benchmark: each a pure function of a time grid.

Every function takes the time t (s) and an amplitude in degrees and returns the commanded front
steering angle in radians. Before the manoeuvre starts the command is zero (straight driving),
except for the slalom, which starts at its extreme like the thesis' input (5.5).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from ..settings import SpeedRamp

__all__ = ["MANOEUVRES", "SPEED_PROFILES", "braking_in_turn", "braking_in_turn_speed", "chirp", "double_lane_change", "slalom",
           "speed_command", "steering_command", "step_steer"]


def slalom(t, amplitude_deg: float = 5.0, period: float = 4.0, sign: float = 1.0, phase: float = 0.0):
    """Slalom sign * A cos(2 pi t / period + phase); the thesis' (5.5) is A = 5 deg, period 4 s,
    sign +1, phase 0, and (5.7) is sign -1.

    Parameters
    ----------
    t : array_like, shape (T,)
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
    ndarray, shape (T,)
        Steering angle (rad).
    """
    t = np.asarray(t, dtype=float)
    return sign * np.deg2rad(amplitude_deg) * np.cos(2.0 * np.pi * t / period + phase)


def step_steer(t, amplitude_deg: float = 2.0, t_start: float = 1.0, ramp: float = 0.4, sign: float = 1.0):
    """Step steer with a smooth ramp: 0 before ``t_start``, a C1 cosine ramp over ``ramp`` s,
    then the constant sign * A.

    Returns
    -------
    ndarray, shape (T,)
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
    ndarray, shape (T,)
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
    ndarray, shape (T,)
        Steering angle (rad).
    """
    t = np.asarray(t, dtype=float)
    a = np.deg2rad(amplitude_deg)
    out = np.zeros_like(t)
    for start, s in ((t_start, 1.0), (t_start + duration + hold, -1.0)):
        inside = (t >= start) & (t <= start + duration)
        out = np.where(inside, s * a * np.sin(2.0 * np.pi * (t - start) / duration), out)
    return sign * out


def braking_in_turn(t, amplitude_deg: float = 2.0, t_start: float = 1.0, ramp: float = 0.4, sign: float = 1.0):
    """Steering of braking in a turn (ISO 7975): a step steer into a steady turn, held while the
    car brakes (:func:`braking_in_turn_speed` gives the speed).

    Returns
    -------
    ndarray, shape (T,)
        Steering angle (rad) on the times ``t``.
    """
    return step_steer(t, amplitude_deg, t_start, ramp, sign)


def braking_in_turn_speed(t, start_kmh: float = 80.0, end_kmh: float = 50.0, t_brake: float = 3.0, duration: float = 3.0):
    """Speed of braking in a turn: constant until ``t_brake``, then a linear decrease to
    ``end_kmh`` over ``duration`` s (80 -> 50 km/h in 3 s is -2.8 m/s^2, 0.28 g), constant after.

    Returns
    -------
    ndarray, shape (T,)
        v(t) (m/s) on the times ``t``.
    """
    return SpeedRamp(start_kmh, end_kmh, duration, t_brake).on(t)



def pulse(t, amplitude_deg: float = 2.0, t_start: float = 1.0, width: float = 0.5, sign: float = 1.0):
    """Rectangular pulse: sign * A on [t_start, t_start + width), 0 elsewhere (a command that
    jumps; on a grid it is held between samples, the data's ``interpolation: previous``).

    Returns
    -------
    ndarray, shape (T,)
        Steering angle (rad) on the times ``t``.
    """
    t = np.asarray(t, dtype=float)
    on = (t >= t_start - 1e-9) & (t < t_start + width - 1e-9)
    return sign * np.deg2rad(amplitude_deg) * on.astype(float)


#: Manoeuvre name -> function(t, ``**params``) returning the steering angle (rad).
MANOEUVRES: dict[str, Callable[..., np.ndarray]] = {
    "slalom": slalom,
    "step": step_steer,
    "chirp": chirp,
    "lane_change": double_lane_change,
    "pulse": pulse,
}

#: Manoeuvres that change the speed: name -> (steering function, speed function (m/s)), each
#: function(t, ``**params``). Kept apart from :data:`MANOEUVRES` (the constant-speed benchmark of
#: discover) because discover models a constant speed.
SPEED_PROFILES: dict[str, tuple[Callable[..., np.ndarray], Callable[..., np.ndarray]]] = {
    "braking_in_turn": (braking_in_turn, braking_in_turn_speed),
}


def steering_command(manoeuvre: str, t, params: Mapping[str, Any] | None = None) -> np.ndarray:
    """Commanded steering angle (rad) of the named manoeuvre on the times ``t`` (s)."""
    if manoeuvre not in MANOEUVRES:
        raise ValueError(f"unknown manoeuvre '{manoeuvre}'; choose one of {', '.join(MANOEUVRES)}")
    return MANOEUVRES[manoeuvre](t, **dict(params or {}))


def speed_command(manoeuvre: str, t, params: Mapping[str, Any] | None = None) -> np.ndarray:
    """Speed (m/s) of the named manoeuvre on the times ``t`` (s); only manoeuvres of
    :data:`SPEED_PROFILES` change the speed."""
    if manoeuvre not in SPEED_PROFILES:
        raise ValueError(f"manoeuvre '{manoeuvre}' keeps a constant speed; speed profiles: {', '.join(SPEED_PROFILES)}")
    return SPEED_PROFILES[manoeuvre][1](t, **dict(params or {}))

"""A sampled command between and after its samples: its reconstruction (linear or held), a dead
time and a first-order lag (the steering actuator's), on uniform grids."""

from __future__ import annotations

import numpy as np

__all__ = ["INTERPOLATIONS", "actual_steering", "checked_interpolation", "held_index", "held_integral", "reconstruction_error"]


#: How a sampled input is reconstructed between its samples (the data schema's ``delta``
#: attribute ``interpolation``): a straight line between samples, or the previous sample held.
INTERPOLATIONS = ("linear", "previous")


def checked_interpolation(interpolation: str) -> str:
    """The reconstruction's name ``interpolation``, one of :data:`INTERPOLATIONS`; else a
    ValueError that names the choices."""
    if interpolation not in INTERPOLATIONS:
        raise ValueError(f"interpolation '{interpolation}' unknown; choose one of {', '.join(INTERPOLATIONS)}")
    return interpolation


def held_index(t, dt: float, delay: float = 0.0):
    """Index of the sample held at times ``t`` - ``delay`` of a zero-order-hold input on the grid
    i dt (the sample at or before that time, -1 before t = 0); shape of ``t``."""
    return np.floor((np.asarray(t, float) - delay) / dt + 1e-9).astype(int)


def actual_steering(delta, dt: float, lag: float = 0.0, delay: float = 0.0, interpolation: str = "linear"):
    """Actual steering angle after a dead time and a first-order lag, from the commanded one.

    Parameters
    ----------
    delta : ndarray, shape (T,)
        Commanded angle on a uniform grid from t = 0 (rad). Before t = 0 the wheel is straight
        (0), as the vehicle's zero initial state implies; a command that starts away from 0
        (the thesis' slalom) is then a step at t = 0 that the actuator follows.
    dt : float
        Grid step (s).
    lag, delay : float
        Time constant T and dead time tau (s).
    interpolation : {"linear", "previous"}
        The command between samples: piecewise linear, or each sample held until the next
        (zero-order hold, :data:`INTERPOLATIONS`).

    Returns
    -------
    ndarray, shape (T,)
        The actual angle at the grid times, exact for either reconstruction. Linear: with
        a = exp(-dt/T), the lag is x_{k+1} = a x_k + b0 u_{k+1} + b1 u_k, b0 = 1 - T (1 - a) / dt,
        b1 = T (1 - a) / dt - a. Held: the delayed command holds u_{k-q-1} on [t_k, t_k + r) and
        u_{k-q} on [t_k + r, t_{k+1}) (tau = q dt + r), so x_{k+1} = a x_k
        + (exp(-(dt - r)/T) - a) u_{k-q-1} + (1 - exp(-(dt - r)/T)) u_{k-q}; without a lag the
        held value at t_k (the step at a sample belongs to the new sample).
    """
    u = np.asarray(delta, float)
    checked_interpolation(interpolation)
    t = np.arange(u.size) * dt
    if interpolation == "previous":
        q = int(np.floor(delay / dt + 1e-9))
        r = max(delay - q * dt, 0.0)

        held = lambda i: np.where(np.asarray(i) >= 0, u[np.clip(i, 0, u.size - 1)], 0.0)  # noqa: E731
        if lag <= 0:
            return held(held_index(t, dt, delay))
        a = np.exp(-dt / lag)
        a_r = np.exp(-(dt - r) / lag) if r > 0 else a
        k = np.arange(u.size - 1)
        return _lag_filter((a_r - a) * held(k - q - 1) + (1.0 - a_r) * held(k - q), a)
    if delay > 0:
        u = np.interp(t - delay, t, u, left=0.0)
    if lag <= 0:
        return u
    a = np.exp(-dt / lag)
    b0 = 1.0 - lag * (1.0 - a) / dt
    b1 = lag * (1.0 - a) / dt - a
    # the step 0 -> u[0] at t = 0 arrives within the first interval (a linear ramp there)
    return _lag_filter(b0 * u[1:] + b1 * u[:-1], a)


def _lag_filter(drive, a: float):
    """x_0 = 0, x_{k+1} = a x_k + drive_k: the lag's recursion, shape (len(drive) + 1,)."""
    from scipy.signal import lfilter

    x, _ = lfilter([1.0], [1.0, -a], drive, zi=[0.0])
    return np.concatenate([[0.0], x])


def held_integral(delta, dt: float, delay: float = 0.0):
    """Integral from 0 of a held (zero-order-hold) command delayed by ``delay``, at the grid
    times (rad s), shape (T,): piecewise linear in time, so a first-order hold of it is exact
    (the held input's own steps are not)."""
    u = np.asarray(delta, float)
    t = np.arange(u.size) * dt
    W = np.concatenate([[0.0], np.cumsum(u[:-1]) * dt])
    return np.interp(t - delay, t, W, left=0.0)


def reconstruction_error(delta, dt: float) -> float:
    """RMS (rad) of the difference between the linear and the held reconstruction of a sampled
    command at mid-sample times: how well the samples alone define the input. An effect that
    changes the input by less (a short lag) cannot be told from the choice of reconstruction.
    The wheel is straight before t = 0, so a command that starts away from 0 jumps there too."""
    u = np.concatenate([[0.0], np.asarray(delta, float)])
    return float(np.sqrt(np.mean((0.5 * np.diff(u)) ** 2)))

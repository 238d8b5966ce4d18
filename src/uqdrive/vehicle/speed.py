"""Speed that changes during a run: a speed profile v(t), the linear time-varying single-track
model along it (exact first-order-hold steps at the local speed) and the NLST with the speed's
effect on the side slip, and the lateral acceleration a_y an IMU records.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any, Mapping

import numpy as np

from ..numerics.discretise import foh_discretise
from ..numerics.integrate import rk4_fixed_step
from .montecarlo import TimeGrid, gust_input_column, wind_yaw_moment
from .single_track import VehicleParameters, lateral_acceleration_map, lst_matrices_at_speed, nlst_rhs

__all__ = ["speed_ramp", "configured_speed", "simulate_lst_ltv", "simulate_nlst_ltv", "lateral_acceleration"]


def speed_ramp(t, start_kmh: float, end_kmh: float, t_start: float = 0.0, duration: float = 1.0):
    """Speed (m/s) that changes linearly from ``start_kmh`` to ``end_kmh`` (km/h) over
    ``duration`` s from ``t_start``, constant before and after (braking or accelerating).

    Parameters
    ----------
    t : array_like
        Time (s).

    Returns
    -------
    ndarray
        v(t) (m/s), same shape as ``t``.
    """
    s = np.clip((np.asarray(t, float) - t_start) / duration, 0.0, 1.0)
    return (start_kmh + (end_kmh - start_kmh) * s) / 3.6


def configured_speed(config: Mapping[str, Any], t) -> np.ndarray | None:
    """The speed profile of ``montecarlo.speed_profile`` on the times ``t`` (m/s), or None when the
    config has none (the constant ``vehicle.speed_kmh``)."""
    ramp = config["montecarlo"].get("speed_profile")
    if not ramp:
        return None
    return speed_ramp(t, ramp["start_kmh"], ramp["end_kmh"], ramp.get("t_start", 0.0), ramp["duration"])


def _step_speeds(v_fine, h: float):
    """Each step's mean speed and slope on a grid of speeds (m/s) at spacing h (s)."""
    return 0.5 * (v_fine[1:] + v_fine[:-1]), np.diff(v_fine) / h


def simulate_lst_ltv(p: VehicleParameters, delta, wind_mean, wind_coeffs, eigenfunctions, grid: TimeGrid, speed, gust_yaw_moment: bool = True):
    """:func:`simulate_lst` along a speed profile: the linear time-varying single-track model.

    Each fine step is discretised exactly (first-order hold) with the matrices at the step's
    mean speed and slope (:func:`lst_matrices_at_speed`), the splitting of
    :class:`uqdrive.vehicle.channels.ChannelChaosModel`.

    Parameters
    ----------
    speed : ndarray, shape (n_fine,)
        v (m/s) on the fine grid; other arguments as :func:`simulate_lst`.

    Returns
    -------
    ndarray, shape (4, n, n_out + 1)
    """
    n = np.shape(wind_mean)[0]
    g = np.column_stack([delta, np.ones_like(delta), np.asarray(eigenfunctions).T])  # (n_fine, r)
    x = np.zeros((n, 4))
    out = np.empty((4, n, grid.n_out + 1))
    out[:, :, 0] = 0.0
    for i, (v, v_dot) in enumerate(zip(*_step_speeds(np.asarray(speed, float), grid.step))):
        A, B, W = lst_matrices_at_speed(p, v, v_dot)
        W_gust = gust_input_column(W, gust_yaw_moment)
        E = np.concatenate([B[:, :, None], (W * np.asarray(wind_mean)[:, None])[:, :, None],
                            W_gust[:, :, None] * np.asarray(wind_coeffs)[:, None, :]], axis=2)
        Phi, P, Q = foh_discretise(A, E, grid.step)
        x = np.einsum("nij,nj->ni", Phi, x) + P @ g[i] + Q @ g[i + 1]
        if (i + 1) % grid.substeps == 0:
            out[:, :, (i + 1) // grid.substeps] = x.T
    return out


def simulate_nlst_ltv(p: VehicleParameters, delta_half, wind_mean, wind_coeffs, eigenfunctions_half, grid: TimeGrid, speed_half,
                      gust_yaw_moment: bool = True):
    """:func:`simulate_nlst` along a speed profile (RK4).

    The speed change acts along the velocity, so the side-slip equation (5.3b) gains the
    projection of the longitudinal force on the velocity's normal:
    beta_dot = (F_y cos beta - m v_dot sin beta) / (m v) - psi_dot, whose linearisation is the
    -v_dot / v beta of :func:`lst_matrices_at_speed`; y_dot = v(t) sin psi.

    Parameters
    ----------
    speed_half : ndarray, shape (2 n_fine - 1,)
        v (m/s) on the half-step grid; other arguments as :func:`simulate_nlst`.
    """
    wind_mean = np.asarray(wind_mean, float)
    coeffs = np.asarray(wind_coeffs, float)
    f_half = np.ascontiguousarray(np.asarray(eigenfunctions_half, float).T)
    v_half = np.asarray(speed_half, float)
    v_dot_half = np.gradient(v_half, grid.step / 2.0)

    def rhs(x, j):
        gust = coeffs @ f_half[j]
        dx = nlst_rhs(x, delta_half[j], wind_mean + gust, replace(p, v_c=v_half[j]), wind_yaw_moment(p.M_c, wind_mean, gust, gust_yaw_moment))
        dx[2] -= v_dot_half[j] / v_half[j] * np.sin(x[2])
        return dx

    out = rk4_fixed_step(rhs, np.zeros((4, n := wind_mean.shape[0])), grid.step, grid.n_out * grid.substeps, grid.substeps)
    return np.ascontiguousarray(out.transpose(1, 2, 0))


def lateral_acceleration(model: str, x, p: VehicleParameters, delta, F_w, speed):
    """Lateral acceleration at the centre of gravity (m/s^2) of simulated states.

    LST: C x + D_delta delta + D_w F_w (:func:`lateral_acceleration_map`); NLST: the lateral
    forces over the mass, (F_fy cos delta + F_ry + F_w) / m = v (beta_dot + psi_dot) / cos beta
    with beta_dot of (5.3b) at constant speed (the forces do not depend on v_dot).

    Parameters
    ----------
    x : ndarray, shape (4, n, T)
    delta : ndarray, shape (T,)
    F_w : ndarray, shape (n, T)
        Side wind on the output grid (N).
    speed : ndarray, shape (T,)
        v (m/s) on the output grid.

    Returns
    -------
    ndarray, shape (n, T)
    """
    out = np.empty(x.shape[1:])
    for k in range(x.shape[2]):
        pk = replace(p, v_c=float(speed[k]))
        if model == "lst":
            C, D_delta, D_w = lateral_acceleration_map(pk)
            out[:, k] = np.einsum("ni,in->n", C, x[:, :, k]) + D_delta * delta[k] + D_w * F_w[:, k]
        else:
            dx = nlst_rhs(x[:, :, k], delta[k], F_w[:, k], pk)
            out[:, k] = speed[k] * (dx[2] + x[1, :, k]) / np.cos(x[2, :, k])
    return out

"""Linear ensemble responses of the single-track model, exact for piecewise-linear inputs (at
constant speed and along a speed profile), and the lateral acceleration of simulated states.

The exact response (:func:`exact_response`) is the one ensemble simulator's
(:class:`uqdrive.vehicle.dynamics.engine.EnsembleSimulator`) for linear structures; the LST along
a speed profile (:func:`simulate_lst_ltv`) is the Monte Carlo data sets' (:func:`uqdrive.vehicle.montecarlo.simulate_ensemble`).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ...numerics.discretise import foh_discretise
from ...numerics.integrate import lti_foh_response
from ...settings import TimeGrid
from ..single_track import VehicleParameters, gust_input_column, input_matrix, lateral_acceleration_map, lst_matrices, lst_matrices_at_speed
from .rhs import HalfStepInputs, SingleTrackRHS

__all__ = ["simulate_lst", "exact_response", "simulate_lst_ltv", "lateral_acceleration"]


def simulate_lst(p: VehicleParameters, delta, wind_mean, wind_coeffs, eigenfunctions, grid: TimeGrid, gust_yaw_moment: bool = True):
    """Ensemble response of the linear single-track model (5.4), exact for piecewise-linear inputs.

    The inputs are written as shared signals g(t) = [delta(t), 1, f_1(t), ..., f_nc(t)] with a
    per-realisation input matrix [B, W F_w_mean, W c_1, ..., W c_nc], so one exact
    discretisation per realisation serves the whole horizon.

    Parameters
    ----------
    p : VehicleParameters
        Per-realisation parameters, arrays of shape (n,).
    delta : ndarray, shape (n_fine,)
        Steering angle on the fine grid (rad).
    wind_mean : ndarray, shape (n,)
        Mean side wind per realisation (N).
    wind_coeffs : ndarray, shape (n, n_c)
        Wind mode coefficients (N), see (5.1), (5.21).
    eigenfunctions : ndarray, shape (n_c, n_fine)
        KLE eigenfunctions on the fine grid (-): the gusts are ``wind_coeffs @ eigenfunctions`` (N).
    grid : TimeGrid
    gust_yaw_moment : bool
        Whether the time-variant wind also exerts the yaw moment M_c F_w.

    Returns
    -------
    ndarray, shape (4, n, n_out + 1)
    """
    return exact_response(lst_matrices(p), delta, wind_mean, wind_coeffs, eigenfunctions, grid.step, grid.substeps, gust_yaw_moment)


def exact_response(matrices, delta, wind_mean, wind_coeffs, eigenfunctions, step: float, stride: int, gust_yaw_moment: bool = True,
                   slip_rate=None, steer=None):
    """States of the linear model x' = A x + E g(t) from rest, exact for piecewise-linear signals
    g(t) = [delta(t), 1, f_1(t), ..., f_nc(t)] (first-order hold, :func:`lti_foh_response`), with
    E = [B, W F_w_mean + b, W_gust c_1, ..., W_gust c_nc] of (5.4), (5.1), (5.21), b a constant
    side-slip rate.

    Every linear ensemble at constant speed is computed here: the ensemble simulator's linear
    structures (:class:`uqdrive.vehicle.dynamics.engine.EnsembleSimulator`: the Monte Carlo LST
    and the augmented model) and :func:`simulate_lst` (:func:`uqdrive.vehicle.montecarlo.lst_response`).

    Parameters
    ----------
    matrices : tuple of ndarray
        A (n, 4, 4), B (n, 4), W (n, 4) of the realisations (:func:`~uqdrive.vehicle.single_track.lst_matrices`),
        in the units of (5.4) (1/s for A's rates).
    delta : ndarray, shape (T,)
        The first signal on the grid (rad): the steering angle, or ``steer``'s signal.
    wind_mean : ndarray, shape (n,)
        Mean side wind per realisation (N).
    wind_coeffs : ndarray, shape (n, n_c)
        Wind mode coefficients (N).
    eigenfunctions : ndarray, shape (n_c, T)
        KLE eigenfunctions on the grid (-).
    step : float
        Grid step (s).
    stride : int
        States returned every ``stride`` steps (the maps of the skipped steps folded exactly).
    gust_yaw_moment : bool
        Whether the gusts also exert the yaw moment M_c F_w.
    slip_rate : float or ndarray, shape (n,), optional
        A constant rate added to beta_dot (rad/s): a road bank's a_lat / v.
    steer : ndarray, shape (n, 4), optional
        The first signal's column (default B), in the units of B.

    Returns
    -------
    ndarray, shape (4, n, T // stride + 1)
    """
    A, B, W = matrices
    W_gust = gust_input_column(W, gust_yaw_moment)
    const = W * np.asarray(wind_mean)[:, None]
    if slip_rate is not None:
        const[:, 2] += slip_rate
    E = input_matrix(B if steer is None else steer, const, W_gust, np.asarray(wind_coeffs))
    g = np.column_stack([delta, np.ones_like(delta), np.asarray(eigenfunctions).T])
    return lti_foh_response(A, E, g, step, stride, np.zeros((A.shape[0], 4)))


def simulate_lst_ltv(p: VehicleParameters, delta, wind_mean, wind_coeffs, eigenfunctions, step: float, stride: int, speed, gust_yaw_moment: bool = True):
    """:func:`simulate_lst` along a speed profile: the linear time-varying single-track model.

    Each fine step is discretised exactly (first-order hold) with the matrices at the step's
    mean speed and slope (:func:`lst_matrices_at_speed`), the splitting of
    :class:`uqdrive.vehicle.channels.ChannelChaosModel` (the same numbers as its moments).

    Parameters
    ----------
    step : float
        Fine grid step (s).
    stride : int
        States returned every ``stride`` fine steps.
    speed : ndarray, shape (n_fine,)
        v (m/s) on the fine grid; other arguments as :func:`simulate_lst`.

    Returns
    -------
    ndarray, shape (4, n, (n_fine - 1) // stride + 1)
    """
    n = np.shape(wind_mean)[0]
    g = np.column_stack([delta, np.ones_like(delta), np.asarray(eigenfunctions).T])  # (n_fine, r)
    x = np.zeros((n, 4))
    out = np.empty((4, n, (g.shape[0] - 1) // stride + 1))
    out[:, :, 0] = 0.0
    speed = np.asarray(speed, float)
    for i, (v, v_dot) in enumerate(zip(0.5 * (speed[1:] + speed[:-1]), np.diff(speed) / step)):
        A, B, W = lst_matrices_at_speed(p, v, v_dot)
        W_gust = gust_input_column(W, gust_yaw_moment)
        E = input_matrix(B, W * np.asarray(wind_mean)[:, None], W_gust, np.asarray(wind_coeffs))
        Phi, P, Q = foh_discretise(A, E, step)
        x = np.einsum("nij,nj->ni", Phi, x) + P @ g[i] + Q @ g[i + 1]
        if (i + 1) % stride == 0:
            out[:, :, (i + 1) // stride] = x.T
    return out


def lateral_acceleration(model: str, x, p: VehicleParameters, delta, F_w, speed):
    """Lateral acceleration at the centre of gravity (m/s^2) of simulated states.

    LST: C x + D_delta delta + D_w F_w (:func:`lateral_acceleration_map`); NLST: the lateral
    forces over the mass, (F_fy cos delta + F_ry + F_w) / m = v (beta_dot + psi_dot) / cos beta
    with beta_dot of (5.3b) at constant speed (the forces do not depend on v_dot).

    Parameters
    ----------
    model : {"lst", "nlst"}
        Linear (5.4) or non-linear (5.3) single-track model.
    x : ndarray, shape (4, n, T)
        States psi (rad), psi_dot (rad/s), beta (rad), y (m) of n realisations.
    p : VehicleParameters
        Parameters, scalars or arrays of shape (n,).
    delta : ndarray, shape (T,)
        Road-wheel steering angle (rad).
    F_w : ndarray, shape (n, T)
        Side wind on the output grid (N).
    speed : ndarray, shape (T,)
        v (m/s) on the output grid.

    Returns
    -------
    ndarray, shape (n, T)
        Lateral acceleration at the centre of gravity (m/s^2).
    """
    out = np.empty(x.shape[1:])
    if model != "lst":  # the output grid as the right-hand side's half-step grid
        rhs = SingleTrackRHS(p, HalfStepInputs(delta, np.asarray(F_w, float).T), speed_half=(speed, None), quotient=True)
        for k in range(x.shape[2]):
            out[:, k] = rhs.lateral_acceleration(x[:, :, k], k)
        return out
    for k in range(x.shape[2]):
        C, D_delta, D_w = lateral_acceleration_map(replace(p, v_c=float(speed[k])))
        out[:, k] = np.einsum("ni,in->n", C, x[:, :, k]) + D_delta * delta[k] + D_w * F_w[:, k]
    return out

"""The reality of the hidden-effect benchmark (:mod:`uqdrive.studies.hidden_effects`): its
right-hand side with the switchable effects, the accelerometer's reading, the braking speed
profile and the RK4 that integrates it, kept apart from the LST/NLST code of :mod:`uqdrive.vehicle`
(the chassis effects' physics in :mod:`uqdrive.studies.hidden.chassis`, apart from :mod:`uqdrive.vehicle.track_extended`).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from ...vehicle.single_track import curvature_argument, magic_formula
from ...vehicle_spec import require
from ..manoeuvres import braking_in_turn_speed
from .chassis import (
    FIXED_POINT_ITERATIONS,
    ROLL_SHARE_FRONT,
    axle_peak,
    compliance_per_force,
    longitudinal_acceleration,
    relaxation_rate,
    roll_acceleration,
    roll_per_g,
    wheel_load_transfer,
)
from ...settings import Settings

__all__ = ["CHASSIS_EFFECTS", "case_speed", "speed_of_case", "reality_rhs", "rk4_left_limit", "state_size"]

#: Effects of the chassis (:mod:`uqdrive.studies.hidden.chassis`): loads moved by the body's accelerations, the steering's
#: compliance, the tyres' relaxation, the roll steer.
CHASSIS_EFFECTS = ("longitudinal_load_transfer", "lateral_load_transfer", "compliance_steer", "tyre_relaxation", "roll_steer")


def state_size(case) -> int:
    """Number of states of the reality: psi, psi_dot, beta, y, then the actual steering angle
    (actuator_lag), then the front and rear lagged slip angles (tyre_relaxation), then the roll
    angle and rate (roll_steer)."""
    return 4 + (case.size("actuator_lag") > 0) + 2 * (case.size("tyre_relaxation") > 0) + 2 * (case.size("roll_steer") != 0)


def speed_of_case(config: Mapping[str, Any], case, t_half):
    """Speed and its rate on a time grid: the case's braking profile, or the config's constant speed.

    Parameters
    ----------
    config : mapping
        Validated configuration (``vehicle.speed_kmh``).
    case : HiddenEffectCase
        Its ``speed``: keyword arguments of :func:`uqdrive.studies.manoeuvres.braking_in_turn_speed`, or empty.
    t_half : ndarray, shape (J,)
        Times (s).

    Returns
    -------
    v, v_dot : ndarray, shape (J,)
        Speed (m/s) and its rate (m/s^2).
    """
    v = case_speed(config, case, t_half)
    return v, (np.gradient(v, t_half) if case.speed else np.zeros(t_half.size))


def case_speed(config: Mapping[str, Any], case, t):
    """Speed (m/s), shape (T,), at times ``t`` (s), shape (T,): the case's braking profile
    (:func:`uqdrive.studies.manoeuvres.braking_in_turn_speed`), or the config's constant speed."""
    if not case.speed:
        return np.full(np.size(t), Settings.from_config(config).vehicle.v_c)
    return braking_in_turn_speed(np.asarray(t, float), **dict(case.speed))


def reality_rhs(config: Mapping[str, Any], case, draws, delta_half, gust_half, delta_left=None, speed_half=None):
    """RK4 right-hand side f(x, j, end) of the reality on the half-step grid index j; ``end``:
    the last stage of a step, which sees the steering's limit from the left ``delta_left``
    (a held command jumps at its samples; default: ``delta_half``, a continuous command).

    x has shape (:func:`state_size`, n): [psi, psi_dot, beta, y], the actual steering angle for
    actuator_lag, the front and rear lagged slip angles for tyre_relaxation. Several effects act
    together (a combined case). The chassis effects (:data:`CHASSIS_EFFECTS`) take each wheel's
    load-sensitive peak (:func:`uqdrive.studies.hidden.chassis.axle_peak`) with the axle loads moved by the body's
    accelerations; lateral_load_transfer reads vehicle.cg_height and vehicle.track_width. ``speed_half``:
    (v, v_dot) per half step along a speed profile (the speed change acts along the velocity:
    beta_dot gains -(v_dot / v) sin beta). ``rhs.a_y(x, j)`` is the accelerometer's reading, the
    lateral tyre and wind forces over the mass (a bank's gravity is not felt).

    Parameters
    ----------
    config : mapping
        Validated configuration (vehicle, tyre, wind; cg_height and track_width for
        lateral_load_transfer).
    case : HiddenEffectCase
        The effects and their sizes.
    draws : mapping
        Per-realisation mu, m_load (kg), l_f (m), F_w_mean (N), each shape (n,).
    delta_half, delta_left : ndarray, shape (J,)
        Actual steering (rad) on the half-step grid, and its limit from the left.
    gust_half : ndarray, shape (J, n)
        Gust force (N) per half step and realisation.
    speed_half : tuple of two ndarrays, shape (J,), optional
        v (m/s) and v_dot (m/s^2) per half step.

    Returns
    -------
    callable
        f(x, j, end) -> dx/dt, shape of x; with the attribute ``a_y(x, j)``
        -> shape (n,) (m/s^2).
    """
    veh, tyre, w = config["vehicle"], config["tyre"], config["wind"]
    v, g, L, M_c = Settings.from_config(config).vehicle.v_c, veh["g"], veh["wheelbase"], veh["M_c"]
    C, E, B_f, B_r = tyre["C"], tyre["E"], veh["c_Sf"], veh["c_Sr"]
    mu, l_f = draws["mu"], draws["l_f"]
    m = veh["m_base"] + draws["m_load"]
    I_z, l_r = m * veh["J0"], L - l_f
    F_fz, F_rz = m * g * l_r / L, m * g * l_f / L
    c_f, c_r = F_fz * B_f * C * mu, F_rz * B_r * C * mu  # slopes of the Magic Formula at zero slip
    inv_Iz, inv_mv = 1.0 / I_z, 1.0 / (m * v)
    v_half, v_dot_half = (None, None) if speed_half is None else speed_half
    w_mean = draws["F_w_mean"]
    gust_moment = bool(w["gust_yaw_moment"])
    present = {e for e, _, _ in case.effects}
    lag, saturating, course = case.size("actuator_lag"), "tyre_saturation" in present, "lateral_kinematics" in present
    bank_acc = g * np.sin(np.deg2rad(case.size("road_bank")))
    bank = bank_acc / v

    delta_left = delta_half if delta_left is None else delta_left
    h_x, p_Dz = case.size("longitudinal_load_transfer"), case.size("lateral_load_transfer")
    K, sigma = case.size("compliance_steer"), case.size("tyre_relaxation")
    chassis = bool(present & set(CHASSIS_EFFECTS))
    if p_Dz != 0:
        purpose = "the hidden effect lateral_load_transfer"
        h_y, track = require(config, "cg_height", purpose), require(config, "track_width", purpose)
    K_F = compliance_per_force(K, m, l_r, L, g)
    i_slip = 4 + (lag > 0)  # first lagged slip angle (tyre_relaxation)
    i_roll = i_slip + 2 * (sigma > 0)  # roll angle and rate (roll_steer)
    roll_steer = case.size("roll_steer")
    if roll_steer != 0:
        h_roll = require(config, "cg_height", "the hidden effect roll_steer")
        # the steer per roll angle (rad/rad) that gives roll_steer deg per g at the nominal mass
        e_f = np.deg2rad(roll_steer) / roll_per_g(veh["m_base"], h_roll, g)
    loop = FIXED_POINT_ITERATIONS if (h_x != 0 or p_Dz != 0 or K != 0) else 0

    def chassis_forces(x, j, d_act, F_w, vj, v_dot):
        """Wheel angle, front and rear forces and, with relaxation, the slip angles' rates."""
        r, beta = x[1], x[2]
        vx, vy = vj * np.cos(beta), vj * np.sin(beta)

        def slips(d):
            if saturating:
                return d - np.arctan((vy + l_f * r) / vx), -np.arctan((vy - l_r * r) / vx)
            return d - beta - l_f * r / vj, l_r * r / vj - beta

        def lateral(alpha, D, B):  # the force across the wheel: the Magic Formula, or its slope B C D
            if saturating:
                return D * np.sin(C * np.arctan(curvature_argument(B * alpha, E)))
            return B * C * D * alpha

        if roll_steer != 0:
            d_act = d_act - e_f * x[i_roll]
        Fz_f, Fz_r, dF_f, dF_r, d = F_fz, F_rz, 0.0, 0.0, d_act
        for k in range(loop + 1):
            a_f, a_r = (x[i_slip], x[i_slip + 1]) if sigma > 0 else slips(d)
            Fy_f = lateral(a_f, axle_peak(Fz_f, dF_f, F_fz, p_Dz, mu), B_f)
            F_r = lateral(a_r, axle_peak(Fz_r, dF_r, F_rz, p_Dz, mu), B_r)
            F_f = Fy_f * np.cos(d) if saturating else Fy_f
            if k == loop:
                break
            tyres = F_f + F_r
            if h_x != 0:
                shift = m * longitudinal_acceleration(beta, (tyres + F_w) / m + bank_acc, v_dot) * h_x / L
                Fz_f, Fz_r = np.maximum(F_fz - shift, 0.0), np.maximum(F_rz + shift, 0.0)
            if p_Dz != 0:
                dF_f = wheel_load_transfer(tyres, h_y, track, ROLL_SHARE_FRONT)
                dF_r = wheel_load_transfer(tyres, h_y, track, 1.0 - ROLL_SHARE_FRONT)
            if K != 0:
                d = d_act - K_F * Fy_f
        rates = None
        if sigma > 0:
            target = slips(d)
            u_f = vx * np.cos(d) + (vy + l_f * r) * np.sin(d) if saturating else vj
            u_r = vx if saturating else vj
            rates = (relaxation_rate(x[i_slip], target[0], u_f, sigma), relaxation_rate(x[i_slip + 1], target[1], u_r, sigma))
        return d, F_f, F_r, rates

    def forces(x, j, end=False):
        """Steering, front and rear tyre forces, wind, 1/(m v), bank / v, v and the lagged slips'
        rates (None without relaxation) at half step j."""
        u = delta_left[j] if end else delta_half[j]
        r, beta = x[1], x[2]
        d = x[4] if lag > 0 else u
        F_w = w_mean + gust_half[j]
        vj, imv, bk = (v, inv_mv, bank) if v_half is None else (v_half[j], 1.0 / (m * v_half[j]), bank_acc / v_half[j])
        if chassis:
            d, F_f, F_r, rates = chassis_forces(x, j, d, F_w, vj, 0.0 if v_half is None else v_dot_half[j])
            return d, F_f, F_r, F_w, imv, bk, vj, rates
        if saturating:  # non-linear single-track model (5.3) of the thesis
            vx, vy = vj * np.cos(beta), vj * np.sin(beta)
            F_f = magic_formula(d - np.arctan((vy + l_f * r) / vx), F_fz, B_f, C, mu, E) * np.cos(d)
            F_r = magic_formula(-np.arctan((vy - l_r * r) / vx), F_rz, B_r, C, mu, E)
        else:  # linear tyres and small angles (5.4)
            F_f = c_f * (d - beta - l_f * r / vj)
            F_r = c_r * (l_r * r / vj - beta)
        return d, F_f, F_r, F_w, imv, bk, vj, None

    def a_y(x, j):
        _, F_f, F_r, F_w, _, _, _, _ = forces(x, j)
        return (F_f + F_r + F_w) / m

    def rhs(x, j, end=False):
        psi, r, beta = x[0], x[1], x[2]
        u = delta_left[j] if end else delta_half[j]
        _, F_f, F_r, F_w, imv, bk, vj, rates = forces(x, j, end)
        M_w = M_c * (F_w if gust_moment else w_mean)
        out = np.empty_like(x)
        out[0] = r
        if saturating:
            out[2] = (F_f + F_r + F_w) * np.cos(beta) * imv - r + bk
            out[3] = vj * np.sin(psi + beta) if course else vj * np.sin(psi)
        else:
            out[2] = (F_f + F_r + F_w) * imv - r + bk
            out[3] = vj * np.sin(psi + beta) if course else vj * psi
        if v_half is not None:
            out[2] -= v_dot_half[j] / vj * (np.sin(beta) if saturating else beta)
        out[1] = (l_f * F_f - l_r * F_r + M_w) * inv_Iz
        if lag > 0:
            out[4] = (u - x[4]) / lag
        if rates is not None:
            out[i_slip], out[i_slip + 1] = rates
        if roll_steer != 0:
            out[i_roll] = x[i_roll + 1]
            out[i_roll + 1] = roll_acceleration(x[i_roll], x[i_roll + 1], F_f + F_r, m, h_roll, g)
        return out

    rhs.a_y = a_y
    return rhs


def rk4_left_limit(rhs, x0, h: float, n_steps: int, every: int) -> np.ndarray:
    """Classical RK4 with the inputs on the half-step grid; the last stage of a step sees the
    inputs' limit from the left (``rhs(x, j, end=True)``).

    Parameters
    ----------
    rhs : callable
        f(x, j, end) of :func:`reality_rhs`.
    x0 : ndarray, shape (d, n)
        Initial state.
    h : float
        Step (s).
    n_steps, every : int
        Steps, and the stride of the returned states.

    Returns
    -------
    ndarray, shape (n_steps // every + 1, d, n)
    """
    out = np.empty((n_steps // every + 1,) + x0.shape)
    out[0] = x = x0
    for k in range(n_steps):
        j = 2 * k
        k1 = rhs(x, j)
        k2 = rhs(x + 0.5 * h * k1, j + 1)
        k3 = rhs(x + 0.5 * h * k2, j + 1)
        k4 = rhs(x + h * k3, j + 2, True)
        x = x + (h / 6.0) * (k1 + 2.0 * (k2 + k3) + k4)
        if (k + 1) % every == 0:
            out[(k + 1) // every] = x
    return out

"""The lane-keeping test case (thesis sec. 5.4, 6.3): LQR and SLQR gains, closed loops simulated
with PCE moments and Monte Carlo on the LST and the NLST, stability, the gamma sweep, and the
table comparing the controllers.
"""

from __future__ import annotations

from typing import Mapping

import numpy as np
import xarray as xr

from .._version import __version__
from ..config import config_hash
from ..control.lqr import lqr_gain
from ..numerics.integrate import lti_foh_response, rk4_fixed_step
from ..vehicle.montecarlo import wind_kle
from ..rng import rng_stream
from ..control.slqr import ClosedLoopChaos, LaneKeepingCase
from ..vehicle.uncertainty import ParameterDistribution
from ..vehicle.dynamics.rhs import SingleTrackRHS
from ..vehicle.single_track import STATES, VehicleParameters, gust_input_column, lst_matrices, wind_yaw_moment
from ..settings import Settings, TimeGrid

__all__ = ["weights", "lqr_mean_gain", "slqr_gain", "closed_loop_monte_carlo", "closed_loop_moments", "gamma_sweep", "distribution_from_theta", "gains_dataset", "controller_table_rows"]


def weights(config):
    """LQR weights of the config: Q = diag(``control.Q_diag``) (4 x 4) and the scalar R."""
    c = config["control"]
    return np.diag(c["Q_diag"]), float(c["R"])


def lqr_mean_gain(config, distribution: ParameterDistribution | None = None) -> np.ndarray:
    """LQR of the LST at the mean parameters (thesis (6.1)), disturbance ignored; shape (4,)."""
    settings = Settings.from_config(config)
    dist = distribution if distribution is not None else ParameterDistribution.from_settings(settings.uncertainty)
    p = VehicleParameters.from_settings(settings, mu=dist.mu[0], m_load=dist.m_load[0], l_f=dist.l_f[0])
    A, B, _ = lst_matrices(p)
    Q, R = weights(config)
    return lqr_gain(A, B, Q, R)[0]


def distribution_from_theta(config, theta, m_load: float | None = None) -> ParameterDistribution:
    """Distributions of an identification estimate (mu, l_f normal, mean wind uniform); the
    load keeps the config's distribution unless a value is given (then it is fixed)."""
    u = config["uncertainty"]
    load = (u["m_load"]["mean"], u["m_load"]["std"]) if m_load is None else (float(m_load), 0.0)
    return ParameterDistribution(mu=(theta[0], abs(theta[1])), m_load=load, l_f=(theta[2], abs(theta[3])), F_w_mean=(theta[4], theta[5]))


def slqr_gain(config, distribution: ParameterDistribution | None = None, gamma: float | None = None, K0=None):
    """SLQR (4.66) minimising (5.38) on [0, T]; returns (K, optimiser result, ClosedLoopChaos)."""
    c = config["control"]
    Q, R = weights(config)
    settings = Settings.from_config(config)
    model = ClosedLoopChaos(settings, LaneKeepingCase.from_settings(settings), distribution, order=c["order"])
    K0 = lqr_mean_gain(config, distribution) if K0 is None else K0
    K, res = model.synthesise(K0, Q, R, c["gamma"] if gamma is None else gamma)
    return K, res, model


def closed_loop_moments(config, K, distribution: ParameterDistribution | None = None) -> dict:
    """PCE mean and variance of the closed loop over the simulation time (Figs 6.16, 6.17)."""
    c = config["control"]
    settings = Settings.from_config(config)
    case = LaneKeepingCase.from_settings(settings, horizon=c["simulation_time"])
    model = ClosedLoopChaos(settings, case, distribution, order=c["order"])
    mean, var, u_mean, u_var = model.moments(K)
    return {"time": model.time, "mean": mean, "variance": var, "u_mean": u_mean, "u_variance": u_var}


def closed_loop_monte_carlo(config, gains: Mapping[str, np.ndarray], model: str, samples: int, seed: int,
                            distribution: ParameterDistribution | None = None) -> xr.Dataset:
    """Monte Carlo of the lane-keeping case for several gains on the same draws.

    LST: exact first-order-hold discretisation of x' = (A + B K) x + W F_w; NLST: RK4 of (5.3)
    with delta = K x. Stability: every eigenvalue of A + B K in the left half plane (LST), and
    a bounded, settled trajectory (NLST: |y| < 0.1 m and |beta| < 0.2 rad at the end).
    """
    c, settings = config["control"], Settings.from_config(config)
    dist = distribution if distribution is not None else ParameterDistribution.from_settings(settings.uncertainty)
    rng = rng_stream(seed, "control", 0 if model == "lst" else 1)
    kle = wind_kle(settings)
    germs = dist.sample_germs(rng, samples)
    xi_wind = rng.standard_normal((samples, kle.n_modes))
    ic = rng.uniform(-1.0, 1.0, (samples, 2))
    draws = dist.from_germs(germs)
    p = VehicleParameters.from_settings(settings, mu=draws["mu"], m_load=draws["m_load"], l_f=draws["l_f"])
    x0 = np.zeros((samples, 4))
    x0[:, 3] = 0.5 * (c["y0"][0] + c["y0"][1]) + 0.5 * (c["y0"][1] - c["y0"][0]) * ic[:, 0]
    x0[:, 0] = np.deg2rad(c["psi0_deg"]) * ic[:, 1]
    coeffs = settings.wind.sigma * xi_wind * np.sqrt(kle.eigenvalues)
    grid = TimeGrid(c["simulation_time"], settings.time.dt, settings.time.step)
    gust_yaw = bool(settings.wind.gust_yaw_moment)
    A, B, W = lst_matrices(p)
    states, steer, stable = [], [], []
    for name, K in gains.items():
        K = np.asarray(K, float).ravel()
        if model == "lst":
            A_cl = A + B[:, :, None] * K[None, None, :]
            t_fine = grid.fine(1)
            g = np.column_stack([np.ones_like(t_fine), kle.eigenfunctions(t_fine).T])
            E = np.concatenate([(W * draws["F_w_mean"][:, None])[:, :, None], gust_input_column(W, gust_yaw)[:, :, None] * coeffs[:, None, :]], axis=2)
            x = lti_foh_response(A_cl, E, g, grid.step, grid.substeps, x0)  # (4, n, T)
            ok = np.linalg.eigvals(A_cl).real.max(axis=1) < 0
        else:
            t_half = grid.fine(2)
            f_half = np.ascontiguousarray(kle.eigenfunctions(t_half).T)
            rhs_vehicle = SingleTrackRHS(p, n=samples).rates
            wind_mean = draws["F_w_mean"]

            def rhs(xs, j):
                gust = coeffs @ f_half[j]
                return rhs_vehicle(xs, K @ xs, wind_mean + gust, wind_yaw_moment(p.M_c, wind_mean, gust, gust_yaw))

            out = rk4_fixed_step(rhs, x0.T.copy(), grid.step, grid.n_out * grid.substeps, grid.substeps)
            x = np.ascontiguousarray(out.transpose(1, 2, 0))
            ok = np.isfinite(x).all(axis=(0, 2)) & (np.abs(x[3, :, -1]) < 0.1) & (np.abs(x[2, :, -1]) < 0.2)
        states.append(x)
        steer.append(np.einsum("i,int->nt", K, x))
        stable.append(ok)
    names = list(gains)
    data = {s: (("controller", "sample", "time"), np.stack([x[i] for x in states])) for i, s in enumerate(STATES)}
    data["delta"] = (("controller", "sample", "time"), np.stack(steer), {"units": "rad", "long_name": "steering u = K x"})
    data["stable"] = (("controller", "sample"), np.stack(stable).astype(np.int8))
    data["K"] = (("controller", "state"), np.stack([np.asarray(gains[n], float).ravel() for n in names]))
    return xr.Dataset(
        data,
        coords={"controller": names, "sample": np.arange(samples), "time": grid.output, "state": list(STATES)},
        attrs={"title": f"lane-keeping test case, {model.upper()} Monte Carlo", "model": model, "seed": int(seed),
               "config_hash": config_hash(config), "uqdrive_version": __version__},
    )


def gamma_sweep(config, distribution: ParameterDistribution | None = None) -> xr.Dataset:
    """SLQR for each gamma: gain, and the mean and variance parts of the LQR-weighted cost
    sum_t x'(Q + K'RK)x on [0, T] (the thesis' open question: can SLQR trade mean for variance?)."""
    c = config["control"]
    Q, R = weights(config)
    K_lqr = lqr_mean_gain(config, distribution)
    settings = Settings.from_config(config)
    model = ClosedLoopChaos(settings, LaneKeepingCase.from_settings(settings), distribution, order=c["order"])

    def parts(K):
        return model.cost(K, Q, R, 1.0), model.cost(K, Q, R, 0.0)  # mean part, variance part

    gains, mean_part, var_part = [], [], []
    K = K_lqr
    for gamma in c["gamma_sweep"]:
        K, _ = model.synthesise(K, Q, R, gamma)  # warm start from the previous gamma
        gains.append(K)
        m, v = parts(K)
        mean_part.append(m)
        var_part.append(v)
    m_lqr, v_lqr = parts(K_lqr)
    return xr.Dataset(
        {"K": (("gamma", "state"), np.array(gains)), "mean_cost": ("gamma", mean_part), "variance_cost": ("gamma", var_part)},
        coords={"gamma": c["gamma_sweep"], "state": list(STATES)},
        attrs={"title": "SLQR gamma sweep", "lqr_mean_cost": m_lqr, "lqr_variance_cost": v_lqr, "K_lqr": K_lqr,
               "seed": int(config["seed"]), "config_hash": config_hash(config), "uqdrive_version": __version__},
    )


def gains_dataset(config, identified_theta=None) -> xr.Dataset:
    """LQR (6.1), SLQR (6.2) on the true distributions and, if given, on identified ones, with
    the PCE moments of each closed loop over the simulation time."""
    gains = {"LQR": lqr_mean_gain(config)}
    K, res, _ = slqr_gain(config)
    gains["SLQR"] = K
    converged = {"SLQR": bool(res.success)}
    if identified_theta is not None:
        dist = distribution_from_theta(config, identified_theta)
        K_id, res_id, _ = slqr_gain(config, dist)
        gains["SLQR identified"] = K_id
        converged["SLQR identified"] = bool(res_id.success)
    names = list(gains)
    moments = [closed_loop_moments(config, gains[n]) for n in names]
    t = moments[0]["time"]
    return xr.Dataset(
        {
            "K": (("controller", "state"), np.array([gains[n] for n in names])),
            "mean": (("controller", "state", "time"), np.array([m["mean"] for m in moments])),
            "variance": (("controller", "state", "time"), np.array([m["variance"] for m in moments])),
            "u_mean": (("controller", "time"), np.array([m["u_mean"] for m in moments])),
            "u_variance": (("controller", "time"), np.array([m["u_variance"] for m in moments])),
        },
        coords={"controller": names, "state": list(STATES), "time": t},
        attrs={"title": "LQR and SLQR gains with PCE closed-loop moments", "gamma": config["control"]["gamma"],
               "horizon": config["control"]["horizon"], "converged": str(converged),
               "identified_theta": np.asarray(identified_theta if identified_theta is not None else [], float),
               "seed": int(config["seed"]), "config_hash": config_hash(config), "uqdrive_version": __version__},
    )


def controller_table_rows(gains: xr.Dataset, lst: xr.Dataset, nlst: xr.Dataset) -> list[dict]:
    """Rows of the controller table: each gain and its Monte Carlo closed loops on LST and NLST.

    Parameters
    ----------
    gains : xarray.Dataset
        The gains (:func:`gains_dataset`); one row per controller, in its order.
    lst, nlst : xarray.Dataset
        Monte Carlo of the closed loops (:func:`closed_loop_monte_carlo`) on the LST and the
        NLST; each must hold every controller of ``gains``.

    Returns
    -------
    list of dict
        Columns ``controller``, ``K`` (the gain, 3 decimals) and, for LST then NLST and each of
        y, beta, delta: the time average over t > 1 s of the absolute Monte Carlo mean
        (``"<model> mean |<var>| (t>1s)"``) and of the sample variance (``"<model> var <var>
        (t>1s)"``), both with 3 significant digits; then ``"<model> unstable runs"`` (int).
    """
    rows = []
    for name in gains["controller"].values:
        row = {"controller": str(name), "K": np.array2string(gains["K"].sel(controller=name).values, precision=3)}
        for model, mc in (("LST", lst), ("NLST", nlst)):
            late = mc["time"].values > 1
            for var in ("y", "beta", "delta"):
                x = mc[var].sel(controller=name).values
                row[f"{model} mean |{var}| (t>1s)"] = f"{np.abs(x.mean(axis=0)[late]).mean():.3g}"
                row[f"{model} var {var} (t>1s)"] = f"{x.var(axis=0, ddof=1)[late].mean():.3g}"
            row[f"{model} unstable runs"] = int((1 - mc["stable"].sel(controller=name).values).sum())
        rows.append(row)
    return rows

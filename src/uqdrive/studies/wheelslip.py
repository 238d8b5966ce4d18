"""The GP paper's results as datasets: GP fit with PID design (Figs 5-8, schedule), slope
calibration, and closed-loop braking with friction curves drawn from the GP posterior.
"""

from __future__ import annotations

from typing import Any, Callable, Mapping

import numpy as np
import xarray as xr

from .._version import __version__
from ..config import config_hash
from ..wheelslip.gp import ArcsineGP
from ..wheelslip.quarter_car import QuarterCar, damping, friction_curve, friction_slope, pid_gains, pid_schedule, simulate_closed_loop
from ..wheelslip.calibration import calibration, design_summary, fit_friction_gp, posterior_curves, prior_calibration, slope_interval_ml
from ..settings import Settings

__all__ = ["gp_dataset", "gp_from_dataset", "calibration_dataset", "closed_loop_dataset", "SLIP_GRID"]

SLIP_GRID = np.linspace(0.0, 1.0, 401)


def _provenance(config, seed_key) -> dict:
    return {"seed": int(config["seed"]), "stream": str(seed_key), "config_hash": config_hash(config), "uqdrive_version": __version__}


def gp_dataset(config: Mapping[str, Any], n: int, rng: np.random.Generator) -> xr.Dataset:
    """Fit the arcsine GP to n noisy points (+ mu(0) = 0) and design the PID on its slope."""
    w = config["wheelslip"]
    car = QuarterCar.from_settings(Settings.from_config(config).wheelslip)
    gp, slip, mu = fit_friction_gp(car, n, w["gp"]["training_slip"], w["gp"]["noise_std"], w["gp"]["restarts"], rng)
    m, v = gp.predict(SLIP_GRID)
    sm, sv = gp.predict_slope(SLIP_GRID)
    slope_mean, slope_std, _ = slope_interval_ml(gp, car.lambda_star)
    design = design_summary(car, slope_mean, slope_std, w["speed"])
    schedule = pid_schedule(slope_mean, car)
    return xr.Dataset(
        {
            "mu_mean": ("slip", m), "mu_std": ("slip", np.sqrt(np.clip(v, 0, None))),
            "slope_mean": ("slip", sm), "slope_std": ("slip", np.sqrt(np.clip(sv, 0, None))),
            "mu_true": ("slip", friction_curve(SLIP_GRID, car.mu_H, car.k)),
            "slope_true": ("slip", friction_slope(SLIP_GRID, car.mu_H, car.k)),
            "train_slip": ("train", slip), "train_mu": ("train", mu),
            "train_exact": ("train", (np.arange(slip.size) == 0).astype(np.int8)),
        },
        coords={"slip": SLIP_GRID},
        attrs={
            "title": f"GP of the friction curve from {n} noisy points",
            "n_train": n, "v1": gp.v1_, "g": gp.g_, "v0": gp.v0_,
            "log_marginal_likelihood": gp.log_marginal_likelihood_,
            "E_Gamma": slope_mean, "var_Gamma": slope_std**2, "true_Gamma": float(friction_slope(car.lambda_star, car.mu_H, car.k)),
            "speed": w["speed"], "lambda_star": car.lambda_star, **design, **schedule, **_provenance(config, f"wheelslip_gp_{n}"),
        },
    )


def gp_from_dataset(ds: xr.Dataset) -> ArcsineGP:
    """The fitted GP again, from the stored training data and hyperparameters."""
    gp = ArcsineGP(hyperparameters={"v1": ds.attrs["v1"], "g": np.atleast_1d(ds.attrs["g"]), "v0": ds.attrs["v0"]})
    return gp.fit(ds["train_slip"].values, ds["train_mu"].values, noise_free=ds["train_exact"].values.astype(bool))


def calibration_dataset(config: Mapping[str, Any], n: int, mcmc_sets: int, hyper: Mapping[str, Any], rng: np.random.Generator,
                        log: Callable[[str], None] | None = None) -> xr.Dataset:
    """Coverage of the true slope by the 95 % interval over many training sets (ML and emcee),
    and the exact check with truths drawn from the GP prior with hyperparameters ``hyper``;
    ``log`` receives progress lines."""
    w = config["wheelslip"]
    c = w["calibration"]
    car = QuarterCar.from_settings(Settings.from_config(config).wheelslip)
    mcmc = {"sets": mcmc_sets, "walkers": c["walkers"], "steps": c["steps"], "burn": c["burn"]} if mcmc_sets else None
    res = calibration(car, n, c["sets"], w["gp"]["training_slip"], w["gp"]["noise_std"], w["gp"]["restarts"], rng, mcmc, log=log)
    x_train = np.concatenate([[0.0], np.linspace(*w["gp"]["training_slip"], n)])
    prior_hits, prior_sets = prior_calibration(hyper, x_train, car.lambda_star, c["prior_sets"], rng)
    from ..wheelslip.calibration import binomial_interval

    mc_bounds = res["mcmc_bounds"] if len(res["mcmc_bounds"]) else np.full((0, 2), np.nan)
    return xr.Dataset(
        {
            "ml_bounds": (("set", "bound"), res["ml_bounds"]),
            "mcmc_bounds": (("mcmc_set", "bound"), mc_bounds),
        },
        coords={"bound": ["lower", "upper"]},
        attrs={
            "title": f"slope calibration at lambda* with {n} training points",
            "n_train": n, "truth": res["truth"],
            "ml_hits": res["ml_hits"], "ml_sets": len(res["ml_bounds"]),
            "ml_ci_low": res["ml_interval"][0], "ml_ci_high": res["ml_interval"][1],
            "mcmc_hits": res["mcmc_hits"], "mcmc_sets": len(mc_bounds),
            "mcmc_ci_low": res["mcmc_interval"][0], "mcmc_ci_high": res["mcmc_interval"][1],
            "prior_hits": prior_hits, "prior_sets": prior_sets,
            "prior_ci_low": binomial_interval(prior_hits, prior_sets)[0], "prior_ci_high": binomial_interval(prior_hits, prior_sets)[1],
            **_provenance(config, f"wheelslip_calibration_{n}"),
        },
    )


def closed_loop_dataset(config: Mapping[str, Any], gp_ds: xr.Dataset, rng: np.random.Generator) -> xr.Dataset:
    """Brake the non-linear quarter car with the GP-tuned PID on posterior curves and the truth."""
    w = config["wheelslip"]
    cl = w["closed_loop"]
    car = QuarterCar.from_settings(Settings.from_config(config).wheelslip)
    gp = gp_from_dataset(gp_ds)
    mean_slope = gp_ds.attrs["E_Gamma"]
    curves = posterior_curves(gp, SLIP_GRID, cl["draws"], rng)
    curves = np.vstack([curves, friction_curve(SLIP_GRID, car.mu_H, car.k)])  # last: the true curve
    h = SLIP_GRID[1] - SLIP_GRID[0]
    rows = np.arange(curves.shape[0])

    def mu_of_slip(lam):
        pos = np.clip(lam / h, 0.0, SLIP_GRID.size - 1 - 1e-9)
        i = pos.astype(int)
        f = pos - i
        return (1 - f) * curves[rows, i] + f * curves[rows, i + 1]

    t, x = simulate_closed_loop(
        mu_of_slip, car, lambda v: pid_gains(mean_slope, v, car)[0], lambda v: pid_gains(mean_slope, v, car)[1],
        w["speed"], cl["initial_slip"], cl["t_end"], cl["step"],
    )
    k_star = int(round(car.lambda_star / h))
    slopes = (curves[:, k_star + 1] - curves[:, k_star - 1]) / (2 * h)
    K_p, T_i, _ = pid_gains(mean_slope, w["speed"], car)
    zeta, _ = damping(slopes, w["speed"], K_p, T_i, car)
    slip = x[:, 1, :]
    final = slip[-max(1, len(t) // 10) :]
    stable = np.all(np.isfinite(slip), axis=0) & (np.abs(final - car.lambda_star).max(axis=0) < 0.02) & (slip.max(axis=0) < 1.0)
    keep = slice(None, None, max(1, len(t) // 500))
    return xr.Dataset(
        {
            "slip": (("time", "curve"), slip[keep]),
            "zeta": ("curve", zeta),
            "slope_at_set_point": ("curve", slopes),
            "stable": ("curve", stable.astype(np.int8)),
        },
        coords={"time": t[keep], "curve": np.arange(curves.shape[0])},
        attrs={
            "title": "closed-loop braking with the GP-tuned PID",
            "true_curve_index": curves.shape[0] - 1,
            "zeta_plus": gp_ds.attrs["zeta_plus"], "zeta_minus": gp_ds.attrs["zeta_minus"],
            "fraction_in_band": float(np.mean((zeta[:-1] >= gp_ds.attrs["zeta_minus"]) & (zeta[:-1] <= gp_ds.attrs["zeta_plus"]))),
            "fraction_stable": float(np.mean(stable[:-1])), "true_stable": int(stable[-1]), "zeta_true_curve": float(zeta[-1]),
            "lambda_star": car.lambda_star, **_provenance(config, "wheelslip_closed_loop"),
        },
    )

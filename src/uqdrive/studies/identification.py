"""The thesis' identification experiments (sec. 5.3.2, ch. 6.2) and the ones past it: basic,
inverted steering, initial-guess and noise tests, noise-aware estimation and robust starts;
and the calibration of the error bars and the misfit test of ``uqdrive identify``: many seeded
replicate ensembles of a model the identification represents exactly (m_load known, no gusts),
each identified as the CLI does; the 95 % intervals must cover the truth about 95 % of the time,
the misfit must pass its 99 % threshold about 99 % of the time.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from types import MappingProxyType
from typing import Any, Mapping, Sequence


import numpy as np
import pandas as pd
import xarray as xr

from .._version import __version__
from ..config import config_hash, override_config
from ..inference.identify import DistributionEstimator, WeightContext, initial_guess
from ..numerics.metrics import normalised_w2_normal, normalised_w2_uniform
from ..rng import rng_stream
from ..vehicle.montecarlo import STEERS, simulate_ensemble, wind_kle
from ..vehicle.chaos import LSTChaosModel
from ..vehicle.statistics import kl_divergence_series
from ..vehicle.single_track import STATES, steering_input
from .experiments import EXPERIMENTS, experiment_provenance, experiment_settings
from ..settings import Settings, TimeGrid

__all__ = ["MeasuredMoments", "Estimate", "true_theta", "w2_scores", "run_experiment", "measured_moments", "measured_data_sets", "experiment_plan",
           "replicate_settings", "coverage_study", "coverage_table", "binomial_band"]

UNCERTAIN = ("mu", "l_f", "F_w_mean")
THETA_NAMES = ("mu_mean", "mu_std", "l_f_mean", "l_f_std", "F_w_mean_low", "F_w_mean_high")
DISTRIBUTIONS = ("mu", "l_f", "F_w_mean")


@dataclass(frozen=True)
class MeasuredMoments:
    """Mean and std (4, T) of one data set, with what the weights need."""

    source: str  # "lst" or "nlst"
    steer: str
    mean: np.ndarray
    std: np.ndarray
    delta: np.ndarray
    kl_divergence: np.ndarray | None = None
    noise_variance: np.ndarray | None = None  # (4,), for noise-aware estimation


@dataclass(frozen=True)
class Estimate:
    """One estimation task: a data set, a cost, and whether to remove the noise variance."""

    label: str  # e.g. "LST-STD"
    data: str  # key into the measured data sets
    cost: str
    noise_aware: bool = False
    starts: int = 0
    state_scale: str | None = None  # None: the config's identification.state_scale


def true_theta(config) -> np.ndarray:
    """Distribution parameters of the config in ``theta_names`` order, shape (6,): the truth of the
    simulated experiments."""
    return Settings.from_config(config).uncertainty.theta(UNCERTAIN)


def w2_scores(theta, config, thesis_formula: bool = False) -> np.ndarray:
    """Normalised W2 (5.29)-(5.33) of mu, l_f and the mean wind against the true distributions."""
    u = config["uncertainty"]
    theta = np.asarray(theta, float)
    return np.array(
        [
            normalised_w2_normal(theta[0], theta[1], u["mu"]["mean"], u["mu"]["std"]),
            normalised_w2_normal(theta[2], theta[3], u["l_f"]["mean"], u["l_f"]["std"]),
            normalised_w2_uniform(theta[4], theta[5], u["F_w_mean"]["low"], u["F_w_mean"]["high"], thesis_formula),
        ]
    )


def _fit(settings: Settings, data: MeasuredMoments, task: Estimate, theta0, m_load, rng) -> dict:
    ident = settings.identify
    model = LSTChaosModel(
        settings, uncertain=UNCERTAIN, time_variant_wind=False, order=ident.order, quadrature_points=ident.quadrature_points,
        steer=data.steer, fixed={"m_load": float(m_load)},
    )
    std = data.std
    if task.noise_aware:
        if data.noise_variance is None:
            raise ValueError(f"{task.label}: noise-aware estimation needs the noise variance of the data")
        std = np.sqrt(np.maximum(std**2 - np.asarray(data.noise_variance)[:, None], 0.0))
    scale = task.state_scale or ident.scale()
    est = DistributionEstimator(model, task.cost, starts=task.starts, rng=rng, max_iter=ident.max_iter, wheelbase=settings.vehicle.wheelbase,
                                state_scale=scale, optimiser=ident.optimiser)
    theta0 = physical_start(model, theta0)
    try:
        est.fit(data.mean, std, theta0, WeightContext(data.delta, data.kl_divergence))
    except ValueError as err:  # a non-physical start is reported, not hidden
        return {"theta": np.full(6, np.nan), "theta_std": np.full(6, np.nan), "cost": np.nan, "n_iter": 0, "converged": False, "message": str(err)}
    return {"theta": est.theta_, "theta_std": est.theta_std_, "cost": est.cost_, "n_iter": est.n_iter_, "converged": est.converged_, "message": est.message_}


def physical_start(model: LSTChaosModel, theta0):
    """A far-off guess can put negative friction or l_f outside (0, L) at the outer quadrature
    nodes; halve its standard deviations until the model is physical (recorded by the caller)."""
    theta = np.array(theta0, float)
    for _ in range(20):
        try:
            model.moments(theta)
            return theta
        except ValueError:
            theta[[1, 3]] *= 0.5
    return theta


def run_experiment(
    config: Mapping[str, Any],
    name: str,
    data: Mapping[str, MeasuredMoments],
    tasks: Sequence[Estimate],
    deviations: Sequence[tuple[float, float]],
    m_load_deviation: Sequence[tuple[float, float]],
    rng: np.random.Generator,
    run_data: Sequence[Mapping[str, str]] | None = None,
) -> xr.Dataset:
    """Run every task for every run; run r starts from a guess deviating by deviations[r].

    Parameters
    ----------
    data : mapping of str to MeasuredMoments
        The data sets the tasks refer to.
    deviations, m_load_deviation : sequence of (e_min, e_max)
        Per run, the (5.34) bounds of the initial guess of theta and of the fixed m_load.
    run_data : sequence of mappings, optional
        Per run, a substitution of data keys (the noise test uses one data set per run).
    """
    ident = config["identification"]
    settings = experiment_settings(Settings.from_config(config), name)
    truth = settings.uncertainty.theta(UNCERTAIN)
    m_true = settings.uncertainty.m_load.mean
    n_runs, n_tasks = len(deviations), len(tasks)
    theta = np.full((n_runs, n_tasks, 6), np.nan)
    theta_std = np.full_like(theta, np.nan)
    guess = np.full((n_runs, 6), np.nan)
    m_guess = np.full(n_runs, np.nan)
    cost, n_iter, converged = np.full((n_runs, n_tasks), np.nan), np.zeros((n_runs, n_tasks), int), np.zeros((n_runs, n_tasks), np.int8)
    w2, w2_thesis = np.full((n_runs, n_tasks, 3), np.nan), np.full((n_runs, n_tasks, 3), np.nan)
    for r in range(n_runs):
        guess[r] = initial_guess(truth, *deviations[r], rng)
        lo, hi = guess[r][4], guess[r][5]
        guess[r][4], guess[r][5] = min(lo, hi), max(lo, hi)
        m_guess[r] = initial_guess(np.array([m_true]), *m_load_deviation[r], rng)[0]
        for k, task in enumerate(tasks):
            key = run_data[r].get(task.data, task.data) if run_data else task.data
            out = _fit(settings, data[key], task, guess[r], m_guess[r], rng)
            theta[r, k], theta_std[r, k], cost[r, k] = out["theta"], out["theta_std"], out["cost"]
            n_iter[r, k], converged[r, k] = out["n_iter"], int(out["converged"])
            if np.all(np.isfinite(out["theta"])):
                w2[r, k] = w2_scores(out["theta"], config)
                w2_thesis[r, k] = w2_scores(out["theta"], config, thesis_formula=True)
    names = list(THETA_NAMES)
    return xr.Dataset(
        {
            "theta": (("run", "estimate", "parameter"), theta),
            "theta_std": (("run", "estimate", "parameter"), theta_std, {"long_name": "Gauss-Newton standard error (lower bound)"}),
            "initial_guess": (("run", "parameter"), guess),
            "m_load_guess": ("run", m_guess, {"units": "kg"}),
            "cost": (("run", "estimate"), cost),
            "n_iter": (("run", "estimate"), n_iter),
            "converged": (("run", "estimate"), converged),
            "w2": (("run", "estimate", "distribution"), w2, {"long_name": "normalised 2-Wasserstein distance (corrected 5.31)"}),
            "w2_thesis": (("run", "estimate", "distribution"), w2_thesis, {"long_name": "normalised W2 with the thesis' printed (5.31)"}),
            "deviation": ("run", np.array([d[1] for d in deviations])),
            "truth": ("parameter", truth),
        },
        coords={"run": np.arange(1, n_runs + 1), "estimate": [t.label for t in tasks], "parameter": names, "distribution": list(DISTRIBUTIONS)},
        attrs={
            "title": f"identification experiment: {name}",
            "experiment": name,
            "order": ident["order"], "quadrature_points": ident["quadrature_points"],
            "state_scales": ",".join(sorted({t.state_scale or settings.identify.scale() for t in tasks})),
            "seed": int(config["seed"]), "config_hash": config_hash(experiment_provenance(config, name)), "uqdrive_version": __version__,
        },
    )


def measured_moments(stats: xr.Dataset, source: str, steer: str, delta, kl=None, noise_index: int | None = None) -> MeasuredMoments:
    """Measured moments from a statistics dataset (one noise level of a noise sweep if given)."""
    sel = stats.isel(noise=noise_index) if noise_index is not None else stats
    noise_var = sel["noise_variance"].values if "noise_variance" in sel else None
    return MeasuredMoments(source, steer, sel["mean"].values, sel["std"].values, np.asarray(delta), kl, noise_var)


def experiment_plan(config: Mapping[str, Any], name: str):
    """Tasks, per-run deviations of theta and m_load, and per-run data keys of an experiment.

    Data keys: "lst_normal", "nlst_normal", "nlst_inverted" and, for the noise test,
    "lst_A{i}" / "nlst_A{i}" for the i-th noise level of the config.
    """
    ident = config["identification"]
    runs = ident["runs"]
    nlst = [Estimate(f"NLST-{c.upper()}", "nlst", c) for c in ("std", "inp", "dst")]
    if name == "basic":
        tasks = [Estimate("LST-STD", "lst", "std")] + nlst
        dev = [tuple(ident["basic_deviation"])] * runs
        return tasks, dev, dev, [{"lst": "lst_normal", "nlst": "nlst_normal"}] * runs
    if name == "inverted":
        dev = [tuple(ident["basic_deviation"])] * runs
        return nlst, dev, dev, [{"nlst": "nlst_inverted"}] * runs
    if name == "initial_guess":
        devs = ident["initial_guess_deviations"]
        m = ident["fixed_deviation"]
        tasks = [Estimate("LST-STD", "lst", "std")] + nlst
        return tasks, [(d, d) for d in devs], [(m, m)] * len(devs), [{"lst": "lst_normal", "nlst": "nlst_normal"}] * len(devs)
    if name == "noise":
        levels = [i for i, a in enumerate(config["noise"]["levels"]) if a > 0]
        m = ident["fixed_deviation"]
        tasks = [Estimate("LST-STD", "lst", "std")] + nlst + [
            Estimate("LST-STD noise-aware", "lst", "std", noise_aware=True),
            Estimate("NLST-STD noise-aware", "nlst", "std", noise_aware=True),
        ]
        return tasks, [(m, m)] * len(levels), [(m, m)] * len(levels), [{"lst": f"lst_A{i}", "nlst": f"nlst_A{i}"} for i in levels]
    if name == "no_wind_moment":  # the basic test on data and model without the wind's yaw moment
        tasks = [Estimate("LST-STD", "lst", "std"), Estimate("NLST-STD", "nlst", "std")]
        dev = [tuple(ident["basic_deviation"])] * runs
        return tasks, dev, dev, [{"lst": "lst_normal_no_wind_moment", "nlst": "nlst_normal_no_wind_moment"}] * runs
    if name in ("normalised", "normalised_inverted"):  # the basic / inverted test with unit-free residuals
        scale = Settings.from_config(config).identify.scale(normalised=True)
        dev = [tuple(ident["basic_deviation"])] * runs
        nlst_n = [Estimate(t.label, t.data, t.cost, state_scale=scale) for t in nlst]
        if name == "normalised":
            return [Estimate("LST-STD", "lst", "std", state_scale=scale)] + nlst_n, dev, dev, [{"lst": "lst_normal", "nlst": "nlst_normal"}] * runs
        return nlst_n, dev, dev, [{"nlst": "nlst_inverted"}] * runs
    if name == "robust":
        devs = ident["robust_deviations"]
        m = ident["fixed_deviation"]
        tasks = [
            Estimate("LST-STD", "lst", "std"),
            Estimate("LST-STD multi-start", "lst", "std", starts=ident["robust_starts"]),
            Estimate("NLST-STD", "nlst", "std"),
            Estimate("NLST-STD multi-start", "nlst", "std", starts=ident["robust_starts"]),
        ]
        return tasks, [(d, d) for d in devs], [(m, m)] * len(devs), [{"lst": "lst_normal", "nlst": "nlst_normal"}] * len(devs)
    raise ValueError(f"unknown experiment '{name}'; choose one of {', '.join(EXPERIMENTS)}")


def measured_data_sets(config: Mapping[str, Any], stats: Mapping[str, xr.Dataset]) -> dict:
    """All data sets of the experiments from statistics datasets keyed "lst_normal",
    "nlst_normal", "lst_inverted", "nlst_inverted", "noise_lst", "noise_nlst".

    The DST weights use D_KL between the noiseless NLST and LST outputs of the same input
    (the synthetic reality is known, sec. 5.3.2), also for the noisy data sets.
    """
    t = Settings.from_config(config).time.output
    st = config["steering"]
    delta = {s: steering_input(t, np.deg2rad(st["delta_max_deg"]), st["period"], STEERS[s]) for s in STEERS}
    kl = {s: kl_divergence_series(stats[f"nlst_{s}"], stats[f"lst_{s}"]).values for s in STEERS if f"nlst_{s}" in stats and f"lst_{s}" in stats}
    data = {}
    for steer in STEERS:
        for source in ("lst", "nlst"):
            key = f"{source}_{steer}"
            if key in stats:
                data[key] = measured_moments(stats[key], source, steer, delta[steer], kl.get(steer))
            if f"{key}_no_wind_moment" in stats:
                data[f"{key}_no_wind_moment"] = measured_moments(stats[f"{key}_no_wind_moment"], source, steer, delta[steer])
    for source in ("lst", "nlst"):
        noisy = stats.get(f"noise_{source}")
        if noisy is not None:
            for i in range(noisy.sizes["noise"]):
                data[f"{source}_A{i}"] = measured_moments(noisy, source, "normal", delta["normal"], kl.get("normal"), i)
    return data


# -- calibration of the error bars and the misfit test ------------------------------------------
Z95 = 1.959963984540054


def replicate_settings(settings: Settings, dt: float) -> Settings:
    """The settings on a coarser output grid (``dt`` s, step dt / 2) with m_load known (std 0) and
    no gusts: data the identification model represents exactly, up to its PCE truncation. Its
    ensembles' provenance records the same changes."""
    u, t = settings.uncertainty, settings.time
    changes = {"uncertainty.m_load.std": 0.0, "wind.sigma": 0.0, "time.dt": float(dt), "time.step": float(dt) / 2.0}
    prov = settings.ensemble_provenance
    return replace(settings, uncertainty=replace(u, m_load=replace(u.m_load, std=0.0)), wind=replace(settings.wind, sigma=0.0),
                   time=TimeGrid(t.t_end, float(dt), float(dt) / 2.0),
                   ensemble_provenance=None if prov is None else MappingProxyType(override_config(prov, changes)))


def coverage_study(config: Mapping[str, Any], replicates: int, samples: int, dt: float = 0.1, seed: int | None = None,
                   state_scale: str = "rms_mean", optimiser: str = "gauss_newton") -> pd.DataFrame:
    """Identify ``replicates`` independent LST ensembles of ``samples`` realisations each.

    Parameters
    ----------
    config : mapping
        Validated configuration; its uncertainty section is the truth.
    replicates, samples : int
        Number of data sets and realisations per data set.
    dt : float
        Output grid (s) of the replicates (coarse: the test is about the statistics, not the grid).
    seed : int, optional
        Root of the replicates' streams (default: the config's seed).
    state_scale : str
        Residual scale of the fits (the CLI's default).
    optimiser : str
        Local optimiser (both reach the same optimum; Gauss-Newton in a third of the iterations).

    Returns
    -------
    pandas.DataFrame
        One row per replicate and parameter: estimate, standard error, lo95, hi95, covered,
        and per replicate the misfit, its threshold and whether it passed.
    """
    settings = replicate_settings(Settings.from_config(config), dt)
    seed = int(settings.seed if seed is None else seed)
    ident = settings.identify
    model = LSTChaosModel(settings, uncertain=UNCERTAIN, time_variant_wind=False, order=ident.order, quadrature_points=ident.quadrature_points)
    truth = settings.uncertainty.theta(UNCERTAIN)
    kle = wind_kle(settings)
    rows = []
    for r in range(replicates):
        ds = simulate_ensemble(settings, "lst", samples=samples, seed=seed + r, kle=kle)
        runs = np.stack([ds[s].values for s in STATES]).astype(float)
        mean, std = runs.mean(axis=1), runs.std(axis=1, ddof=1)
        start = initial_guess(truth, 0.05, 0.15, rng_stream(seed, "identify_coverage", r))
        est = DistributionEstimator(model, "std", state_scale=state_scale, wheelbase=settings.vehicle.wheelbase, optimiser=optimiser,
                                    rng=rng_stream(seed, "identify_reference", r)).fit(mean, std, start, runs=runs)
        ref = est.misfit_reference_
        for i, name in enumerate(model.theta_names):
            se = est.theta_std_[i]
            if name in est.upper_bounds_:
                lo, hi = 0.0, est.upper_bounds_[name]
            else:
                lo, hi = est.theta_[i] - Z95 * se, est.theta_[i] + Z95 * se
            rows.append({"replicate": r, "parameter": name, "truth": truth[i], "estimate": est.theta_[i], "standard_error": se,
                         "lo95": lo, "hi95": hi, "covered": bool(lo <= truth[i] <= hi), "converged": est.converged_,
                         "misfit": est.cost_, "expected_misfit": ref.expected, "threshold": ref.threshold,
                         "gof_passed": bool(est.cost_ <= ref.threshold)})
    return pd.DataFrame(rows)


def binomial_band(n: int, p: float = 0.95, alpha: float = 0.01) -> tuple[float, float]:
    """Central (1 - alpha) range of the hit rate of n Bernoulli(p) trials (a coverage rate
    outside it is inconsistent with p at level alpha)."""
    from scipy.stats import binom  # here: scipy.stats costs ~1 s of import in every process that imports this module

    return float(binom.ppf(alpha / 2, n, p) / n), float(binom.isf(alpha / 2, n, p) / n)


def coverage_table(results: pd.DataFrame, alpha: float = 0.01) -> pd.DataFrame:
    """Per parameter: replicates, 95 % coverage, its binomial band, mean |estimate - truth| in
    standard errors, the ratio of the empirical spread of the estimates to the mean standard
    error; and the goodness-of-fit pass rate (one row "misfit")."""
    out = []
    n = int(results["replicate"].nunique())
    lo, hi = binomial_band(n, 0.95, alpha)
    for name, g in results.groupby("parameter", sort=False):
        out.append({"parameter": name, "replicates": n, "coverage_95": float(g["covered"].mean()), "band_lo": lo, "band_hi": hi,
                    "spread_over_se": float(np.std(g["estimate"], ddof=1) / np.nanmean(g["standard_error"]))})
    per = results.drop_duplicates("replicate")
    glo, ghi = binomial_band(n, 0.99, alpha)
    out.append({"parameter": "misfit (99 % test)", "replicates": n, "coverage_95": float(per["gof_passed"].mean()), "band_lo": glo,
                "band_hi": ghi, "spread_over_se": float("nan")})
    return pd.DataFrame(out)

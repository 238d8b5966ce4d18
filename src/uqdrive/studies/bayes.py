"""The emcee cross-check as experiments: LST-LST, NLST-LST and a noisy case, each with the
optimiser estimate, the posterior of four ensembles, diagnostics, a coverage check, and the
summary table of the posteriors.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any, Mapping

import numpy as np
import xarray as xr

from .._version import __version__
from ..inference.bayes import BoxPrior, MomentLikelihood, chain_dataset, log_posteriors, sample_ensembles
from ..config import config_hash
from ..inference.identify import DistributionEstimator
from ..vehicle.montecarlo import simulate_ensemble
from ..vehicle.noise import add_noise, estimate_noise_variance
from ..vehicle.chaos import LSTChaosModel
from ..rng import rng_stream
from ..vehicle.statistics import used_samples
from ..vehicle.single_track import STATES
from ..settings import Settings

__all__ = ["CASES", "prepare_data", "posterior_case", "summarise", "posterior_table_rows", "coverage_study"]

UNCERTAIN = ("mu", "l_f", "F_w_mean")
CASES = ("lst", "nlst", "lst_noise")


def prepare_data(config: Mapping[str, Any], ensemble: xr.Dataset, noise_level: float = 0.0):
    """Realisations (4, N, T) used for statistics (spin policy), noisy if asked, and the noise
    variance estimated from them (per state; zero for clean data)."""
    mask = used_samples(ensemble, config["montecarlo"]["spin_policy"])
    if noise_level > 0:
        rng = rng_stream(config["seed"], "noise", round(noise_level * 1e6))  # the noise test's own draws
        x = np.stack([add_noise(ensemble[s].values, noise_level, rng)[mask] for s in STATES])
        noise_var = np.array([estimate_noise_variance(x[i]) for i in range(4)])
    else:
        x = np.stack([ensemble[s].values[mask] for s in STATES])
        noise_var = None
    return x, noise_var


def _model(settings: Settings, dt=None, m_load=None, gusts: bool = False):
    """The Table 5.4 model (``gusts``: plus the KLE gusts of known F_w,sigma, as in the data),
    on the output grid ``dt`` (s) when given."""
    if dt is not None:
        settings = settings.with_time(replace(settings.time, dt=dt))
    m_load = settings.uncertainty.m_load.mean if m_load is None else m_load
    ident = settings.identify
    return LSTChaosModel(settings, uncertain=UNCERTAIN, time_variant_wind=gusts, order=ident.order,
                         quadrature_points=ident.quadrature_points, fixed={"m_load": m_load})


def _models(config):
    """The optimiser's model (full grid) and the sampler's (``bayes.model_dt``, gusts if asked)."""
    b, settings = config["bayes"], Settings.from_config(config)
    return _model(settings), _model(settings, dt=b["model_dt"], gusts=b.get("model_gusts", False))


def _setup_case(config: Mapping[str, Any], x, noise_var, rng: np.random.Generator, ensembles, models) -> dict:
    """Optimiser estimates, the likelihood target and the ensembles' starts of one case.

    Returns a dict with ``target`` (likelihood, prior, index on the sampler's grid observed
    every ``every`` samples), ``every``, ``starts`` (one per ensemble) and ``attrs``.
    """
    b = config["bayes"]
    dt = config["time"]["dt"]
    mean, std = x.mean(axis=1), x.std(axis=1, ddof=1)
    if noise_var is not None:  # noise-aware, as the identification's past-the-thesis estimate
        std = np.sqrt(np.maximum(std**2 - noise_var[:, None], 0.0))
    full, coarse = models
    settings = Settings.from_config(config)
    ident = settings.identify
    truth = settings.uncertainty.theta(UNCERTAIN)
    est, unit_free = (
        DistributionEstimator(full, "std", max_iter=ident.max_iter, wheelbase=settings.vehicle.wheelbase,
                              state_scale=ident.scale(normalised), optimiser=ident.optimiser).fit(mean, std, truth)
        for normalised in (False, True)
    )
    for name, step in (("time.dt", dt), ("bayes.model_dt", b["model_dt"])):
        ratio = b["likelihood_dt"] / step
        if abs(ratio - round(ratio)) > 1e-9:
            raise ValueError(f"bayes.likelihood_dt = {b['likelihood_dt']} must be a multiple of {name} = {step}: the model and the data must share the likelihood times")
    stride = int(round(b["likelihood_dt"] / dt))
    every = int(round(b["likelihood_dt"] / b["model_dt"]))
    data_idx = np.arange(stride, x.shape[2], stride)
    # The likelihood times are every `every`-th model time: the sampler's model computes only those.
    target = (MomentLikelihood.from_samples(x[:, :, data_idx], b["model_error"], noise_var), BoxPrior.from_settings(settings), data_idx // stride)
    n_ens = b["ensembles"] if ensembles is None else ensembles
    centre = est.theta_.copy()
    starts = [centre] + [centre * (1.0 + b["dispersion"] * rng.standard_normal(centre.size)) for _ in range(n_ens - 1)]
    admissible = log_posteriors(coarse, [(np.array(starts), *target)], every)[0]
    starts = [s if np.isfinite(lp) else centre for s, lp in zip(starts, admissible)]
    attrs = {"optimiser_estimate": est.theta_, "optimiser_converged": int(est.converged_), "truth": truth,
             "optimiser_estimate_unit_free": unit_free.theta_, "unit_free_state_scale": ident.scale(normalised=True),
             "likelihood_times": int(data_idx.size), "model_gusts": int(b.get("model_gusts", False)), "moves": b.get("moves", "stretch"), "n_samples": int(x.shape[1]), "seed": int(config["seed"]),
             "config_hash": config_hash(config), "uqdrive_version": __version__}
    return {"target": target, "every": every, "starts": starts, "attrs": attrs}


def _sample(config, cases, coarse, rng, max_steps, progress=False, log=None):
    """All ensembles of all cases at once (:func:`sample_ensembles` in lockstep): every update of
    every ensemble's half-walkers is one batched model call; the runs, grouped by case."""
    b = config["bayes"]
    owner = [c for c, case in enumerate(cases) for _ in case["starts"]]

    def log_prob(calls):
        return log_posteriors(coarse, [(thetas, *cases[owner[i]]["target"]) for i, thetas in calls], cases[0]["every"])

    runs = sample_ensembles(log_prob, [s for case in cases for s in case["starts"]], b["walkers"], rng,
                            b["max_steps"] if max_steps is None else max_steps, b["check_every"], b["tau_factor"], progress=progress,
                            burn_in=b.get("burn_in", 0), moves=b.get("moves", "stretch"), lockstep=True, log=log)
    return [[r for r, o in zip(runs, owner) if o == c] for c in range(len(cases))]


def posterior_case(config: Mapping[str, Any], x, noise_var, rng: np.random.Generator, ensembles=None, max_steps=None, progress=False, log=None):
    """Optimiser estimate (STD cost, full grid) and its emcee posterior (aggregated likelihood).

    The ensembles run in lockstep with one batched PCE evaluation per half-ensemble update of
    all of them (:func:`uqdrive.inference.bayes.sample_ensembles`); each chain is the one it has alone.
    ``log`` receives progress lines.
    """
    models = _models(config)
    case = _setup_case(config, x, noise_var, rng, ensembles, models)
    runs = _sample(config, [case], models[1], rng, max_steps, progress, log)[0]
    return chain_dataset(runs, models[0].theta_names, case["attrs"])


def summarise(ds: xr.Dataset) -> dict:
    """Posterior mean and 95 % interval per parameter from all ensembles after burn-in/thinning."""
    pooled = []
    for e in range(ds.sizes["ensemble"]):
        burn, thin = int(ds["burn"][e]), int(ds["thin"][e])
        c = ds["chain"].values[e][burn::thin]
        pooled.append(c[np.all(np.isfinite(c), axis=(1, 2))].reshape(-1, ds.sizes["parameter"]))
    s = np.concatenate(pooled)
    lo, hi = np.percentile(s, [2.5, 97.5], axis=0)
    est, truth = np.asarray(ds.attrs["optimiser_estimate"]), np.asarray(ds.attrs["truth"])
    out = {"mean": s.mean(axis=0), "low": lo, "high": hi, "samples": s.shape[0],
           "contains_estimate": (lo <= est) & (est <= hi), "contains_truth": (lo <= truth) & (truth <= hi)}
    if "optimiser_estimate_unit_free" in ds.attrs:
        free = np.asarray(ds.attrs["optimiser_estimate_unit_free"])
        out["contains_estimate_unit_free"] = (lo <= free) & (free <= hi)
    return out


def posterior_table_rows(posteriors: Mapping[str, xr.Dataset], titles: Mapping[str, str], summaries: Mapping[str, dict] | None = None) -> list[dict]:
    """Rows of the posterior summary table: one per case and parameter, formatted for the CSV.

    Parameters
    ----------
    posteriors : mapping of str to xarray.Dataset
        Posterior datasets of :func:`posterior_case` by case (e.g. ``lst``), with the attribute
        ``seconds`` (sampling wall time) added by the workflow; rows follow this order.
    titles : mapping of str to str
        Title of each case, the table's ``case`` column.
    summaries : mapping of str to dict, optional
        :func:`summarise` of each case, if already computed; computed here otherwise.

    Returns
    -------
    list of dict
        Columns ``case``, ``parameter``, ``posterior mean``, ``95% interval``, ``optimiser``,
        ``optimiser (unit-free)`` (empty when the dataset lacks that estimate), ``truth``,
        ``tau`` (largest over the ensembles), ``N/tau`` (smallest over the ensembles, N the
        finite steps of each), ``R-hat``, ``ESS`` and ``seconds``; all values are strings.
    """
    rows = []
    for case, ds in posteriors.items():
        s = summaries[case] if summaries is not None else summarise(ds)
        n_steps = np.array([np.isfinite(ds["chain"].values[e, :, 0, 0]).sum() for e in range(ds.sizes["ensemble"])])
        for j, name in enumerate(ds["parameter"].values):
            rows.append({"case": titles[case], "parameter": str(name), "posterior mean": f"{s['mean'][j]:.4g}",
                         "95% interval": f"[{s['low'][j]:.4g}, {s['high'][j]:.4g}]", "optimiser": f"{ds.attrs['optimiser_estimate'][j]:.4g}",
                         "optimiser (unit-free)": f"{ds.attrs['optimiser_estimate_unit_free'][j]:.4g}" if "optimiser_estimate_unit_free" in ds.attrs else "",
                         "truth": f"{ds.attrs['truth'][j]:.4g}", "tau": f"{np.nanmax(ds['tau'].values[:, j]):.0f}",
                         "N/tau": f"{np.nanmin(n_steps / ds['tau'].values[:, j]):.0f}", "R-hat": f"{ds['r_hat'].values[j]:.3f}",
                         "ESS": f"{ds['ess'].values[j]:.0f}", "seconds": f"{ds.attrs['seconds']:.0f}"})
    return rows


def coverage_study(config: Mapping[str, Any], sets: int, steps: int, rng: np.random.Generator, log=None):
    """LST-LST on independently simulated ensembles: how often the 95 % intervals hold the truth.

    One ensemble per set; the sets' samplers run together in lockstep (one batched PCE call per
    update of all of them), each with its own data, likelihood and random stream, drawn in the
    order of the one-set-at-a-time loop, so each set's chain is the one it has alone.
    """
    models = _models(config)
    cases = []
    for k in range(sets):
        ens = simulate_ensemble(Settings.from_config(config), "lst", seed=int(config["seed"]) + 1000 + k)
        x, _ = prepare_data(config, ens)
        cases.append(_setup_case(config, x, None, rng, 1, models))
        del ens, x
        if log is not None:
            log(f"set {k}: optimiser estimates done")
    runs = _sample(config, cases, models[1], rng, steps, log=log)
    hits, total = 0, 0
    per_set = []
    for case, case_runs in zip(cases, runs):
        s = summarise(chain_dataset(case_runs, models[0].theta_names, case["attrs"]))
        hits += int(s["contains_truth"].sum())
        total += s["contains_truth"].size
        per_set.append(s["contains_truth"].astype(int))
    return hits, total, np.array(per_set)

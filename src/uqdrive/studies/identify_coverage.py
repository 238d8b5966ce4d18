"""Calibration of the identification's error bars and goodness-of-fit test: many seeded replicate
ensembles of a model the identification can represent exactly (the Table 5.4 model: m_load known,
no gusts), each identified as ``uqdrive identify`` does; the 95 % intervals must cover the truth
about 95 % of the time and the misfit must pass its 99 % threshold about 99 % of the time.
"""

from __future__ import annotations

import copy
from typing import Any, Mapping

import numpy as np
import pandas as pd
from scipy import stats

from ..inference.identify import DistributionEstimator, initial_guess, state_weights  # noqa: F401  (state_weights: the CLI's check)
from ..rng import rng_stream
from ..vehicle.chaos import LSTChaosModel
from ..vehicle.montecarlo import simulate_ensemble
from ..vehicle.single_track import STATES

__all__ = ["UNCERTAIN", "replicate_config", "coverage_study", "coverage_table", "binomial_band"]

UNCERTAIN = ("mu", "l_f", "F_w_mean")
Z95 = 1.959963984540054


def replicate_config(config: Mapping[str, Any], dt: float) -> dict:
    """The config on a coarser output grid with m_load known (std 0) and no gusts: data the
    identification model represents exactly, up to its PCE truncation."""
    cfg = copy.deepcopy(dict(config))
    cfg["uncertainty"]["m_load"] = dict(cfg["uncertainty"]["m_load"], std=0.0)
    cfg["wind"] = dict(cfg["wind"], sigma=0.0)
    cfg["time"] = dict(cfg["time"], dt=float(dt), step=float(dt) / 2.0)
    return cfg


def coverage_study(config: Mapping[str, Any], replicates: int, samples: int, dt: float = 0.1, seed: int | None = None,
                   state_scale: str = "rms_mean") -> pd.DataFrame:
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

    Returns
    -------
    pandas.DataFrame
        One row per replicate and parameter: estimate, standard error, lo95, hi95, covered,
        and per replicate the misfit, its threshold and whether it passed.
    """
    cfg = replicate_config(config, dt)
    seed = int(cfg["seed"] if seed is None else seed)
    ident = cfg["identification"]
    model = LSTChaosModel(cfg, uncertain=UNCERTAIN, time_variant_wind=False, order=ident["order"], quadrature_points=ident["quadrature_points"])
    truth = LSTChaosModel.theta_from_config(cfg, UNCERTAIN)
    rows = []
    for r in range(replicates):
        ds = simulate_ensemble(cfg, "lst", samples=samples, seed=seed + r)
        runs = np.stack([ds[s].values for s in STATES]).astype(float)
        mean, std = runs.mean(axis=1), runs.std(axis=1, ddof=1)
        start = initial_guess(truth, 0.05, 0.15, rng_stream(seed, "identify_coverage", r))
        est = DistributionEstimator(model, "std", state_scale=state_scale, wheelbase=cfg["vehicle"]["wheelbase"],
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
    return float(stats.binom.ppf(alpha / 2, n, p) / n), float(stats.binom.isf(alpha / 2, n, p) / n)


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

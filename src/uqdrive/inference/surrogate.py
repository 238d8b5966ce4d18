"""Quadratic response surfaces that stand in for an expensive model in a posterior (design, least
squares), and the check of how far the surrogate's error moves the posterior it stands in for."""

from __future__ import annotations

from functools import lru_cache

import numpy as np

__all__ = ["quadratic_features", "fit_quadratic", "gaussian_design", "first_order_shift"]


@lru_cache(maxsize=16)
def _pairs(p: int):
    return np.triu_indices(p)


def quadratic_features(u):
    """Full quadratic basis 1, u_i, u_i u_j (i <= j).

    Parameters
    ----------
    u : ndarray, shape (B, p)

    Returns
    -------
    ndarray, shape (B, 1 + p + p (p + 1) / 2)
    """
    u = np.atleast_2d(np.asarray(u, float))
    i, j = _pairs(u.shape[1])
    return np.concatenate([np.ones((u.shape[0], 1)), u, u[:, i] * u[:, j]], axis=1)


def fit_quadratic(u, y):
    """Least-squares coefficients of a quadratic in u for every column of y.

    Parameters
    ----------
    u : ndarray, shape (n, p)
        Design points (whitened coordinates).
    y : ndarray, shape (n, m)
        Responses.

    Returns
    -------
    ndarray, shape (n_terms, m)
        ``quadratic_features(u) @ coef`` approximates y.
    """
    coef, *_ = np.linalg.lstsq(quadratic_features(u), np.asarray(y, float), rcond=None)
    return coef


def gaussian_design(n: int, p: int, spread: float, rng: np.random.Generator):
    """Space-filling standard-normal design: a Latin hypercube mapped through the normal
    quantile, times ``spread``; the first point is the centre (0).

    Returns
    -------
    ndarray, shape (n, p)
    """
    from scipy.stats import norm, qmc

    cube = qmc.LatinHypercube(d=p, seed=rng).random(max(n - 1, 1))
    return np.vstack([np.zeros((1, p)), spread * norm.ppf(cube)])[:n]


def first_order_shift(samples, error):
    """How far a log-density error moves each parameter's posterior mean and standard deviation,
    to first order, in posterior standard deviations.

    Draws x_s from the surrogate posterior q and the error delta_s = log p(x_s) - log q(x_s) (up
    to a constant) give the exact posterior's moments as q's tilted by exp(delta). To first order
    in delta, E_p[x] - E_q[x] = Cov_q(x, delta) and Var_p[x] - Var_q[x] = Cov_q((x - E_q x)^2,
    delta); in the standardised z = (x - E_q x) / sd_q the shifts are

        d_mean = Cov(z, delta),    d_sd = Cov(z^2, delta) / 2,

    exact for a Gaussian q tilted by delta = g z (d_mean = g) and to first order in c for
    delta = c z^2 (sd ratio 1 / sqrt(1 - 2 c)). Unlike the importance weights exp(delta) they
    estimate, these are linear in delta: a few draws where the surrogate is off by units of log
    density (a heavy tail) move them by their share, not by a weight of e^3.

    Parameters
    ----------
    samples : ndarray, shape (S, p)
        Posterior draws of the surrogate (S >= 3).
    error : ndarray, shape (S,)
        log p - log q at the draws (nats); a constant offset does not matter.

    Returns
    -------
    mean_shift, sd_shift : ndarray, shape (p,)
        d_mean and d_sd (-).
    mean_se, sd_se : ndarray, shape (p,)
        Their standard errors from the S draws (the sample standard deviation of the products
        over sqrt(S)).
    """
    x = np.atleast_2d(np.asarray(samples, float))
    d = np.asarray(error, float)
    if x.shape[0] != d.size or d.size < 3:
        raise ValueError(f"need matching draws and errors, at least 3; got {x.shape[0]} draws and {d.size} errors")
    scale = x.std(axis=0, ddof=1)
    scale = np.where(scale > 0, scale, 1.0)
    z = (x - x.mean(axis=0)) / scale
    d = d - d.mean()
    mean_terms = z * d[:, None]
    sd_terms = 0.5 * (z**2 - np.mean(z**2, axis=0)) * d[:, None]
    S = d.size
    mean_shift, sd_shift = mean_terms.sum(axis=0) / (S - 1), sd_terms.sum(axis=0) / (S - 1)
    return mean_shift, sd_shift, mean_terms.std(axis=0, ddof=1) / np.sqrt(S), sd_terms.std(axis=0, ddof=1) / np.sqrt(S)

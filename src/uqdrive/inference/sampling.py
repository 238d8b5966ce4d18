"""Sampling error of an identification from ensemble moments: sandwich standard errors and a
calibrated goodness-of-fit reference for the cost (5.25).

The measured mean and std trajectories are averages over n realisations, so they carry a sampling
error whose covariance follows from the realisations themselves (their influence functions):

    mean:  IF_i(t) = x_i(t) - m(t)                        Var = sigma^2 / n
    std:   IF_i(t) = ((x_i(t) - m(t))^2 - s(t)^2) / (2 s(t))   Var = (kurtosis - 1) sigma^2 / (4 n)

(delta method; the second form carries the kurtosis of non-Gaussian germs and the correlation of
all states and times, because it is built from the realisations, not from a Gaussian model).
With the weighted residuals r = sqrt(w) [model - data] and their Jacobian J at the estimate, the
linearised estimate is theta - theta* = A eps, A = (J'J)^-1 J', eps = sqrt(w) [IF averaged], so

    Cov(theta) = A Cov(eps) A' = (A F)(A F)' / (n (n - 1)),    F = sqrt(w) [IF_1 ... IF_n]

(the sandwich estimator), and the misfit at the optimum under the fitted model is the part of the
sampling error the parameters cannot absorb, Q = ||(I - J A) eps||^2. Its distribution is a
weighted sum of chi-square variables; its mean is exact (a trace), its variance is estimated by a
Gaussian multiplier bootstrap over the realisations and the two are matched to a scaled
chi-square a chi2_nu (Satterthwaite), whose upper quantile is the threshold of the test.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import special

__all__ = ["RunInfluence", "run_influence", "sandwich_covariance", "MisfitReference", "misfit_reference", "sampling_errors", "gauss_newton_errors"]


@dataclass(frozen=True)
class RunInfluence:
    """Weighted influence of each realisation on the measured statistics.

    Attributes
    ----------
    mean, std : ndarray, shape (n_states, n, T)
        sqrt(w) IF_i of the ensemble mean and of the ensemble std (units of the residuals).
    """

    mean: np.ndarray
    std: np.ndarray

    @property
    def n(self) -> int:
        """Number of realisations whose influences these are."""
        return int(self.mean.shape[1])

    def project(self, A_mean, A_std) -> np.ndarray:
        """sum over states and times of A (p, n_states, T) times the influences: (p, n)."""
        return np.einsum("pst,snt->pn", A_mean, self.mean, optimize=True) + np.einsum("pst,snt->pn", A_std, self.std, optimize=True)


def run_influence(runs, weights) -> RunInfluence:
    """Influence functions of the ensemble mean and std (ddof 1) of ``runs``, weighted.

    Parameters
    ----------
    runs : ndarray, shape (n_states, n, T)
        The realisations the statistics are computed from (after the spin policy).
    weights : ndarray, shape (n_states, T), or a pair of them
        Weights w of the cost (5.25); the influences are multiplied by sqrt(w). A pair
        (w_mean, w_std) weighs the mean's and the std's residuals differently.

    Returns
    -------
    RunInfluence
        Where the ensemble std is zero (all realisations equal, e.g. at t = 0) the std's
        influence is zero.
    """
    x = np.asarray(runs, float)
    d = x - x.mean(axis=1, keepdims=True)
    s = x.std(axis=1, ddof=1, keepdims=True)
    w_mean, w_std = weights if isinstance(weights, (tuple, list)) else (weights, weights)
    sw_mean, sw_std = (np.sqrt(np.asarray(w, float))[:, None, :] for w in (w_mean, w_std))
    safe = np.where(s > 0, s, 1.0)
    infl_std = np.where(s > 0, (d**2 - s**2) / (2.0 * safe), 0.0)
    infl_std -= infl_std.mean(axis=1, keepdims=True)  # sums to zero like the mean's
    return RunInfluence(sw_mean * d, sw_std * infl_std)


def _pseudo_inverse(jac):
    """A = (J'J)^-1 J' (p, m) by a QR factorisation (stable for badly scaled columns), or None
    if J has not full column rank."""
    q, r = np.linalg.qr(jac)
    d = np.abs(np.diag(r))
    if d.size == 0 or d.min() <= 1e-12 * d.max():
        return None
    return np.linalg.solve(r, q.T)


def sandwich_covariance(jac, influence: RunInfluence) -> np.ndarray:
    """Covariance (p, p) of the estimate from the sampling error of the measured statistics.

    Parameters
    ----------
    jac : ndarray, shape (2 n_states T, p)
        d r / d theta of the weighted residuals [mean part, std part] (flattened state-major).
    influence : RunInfluence

    Returns
    -------
    ndarray, shape (p, p)
        (A F)(A F)' / (n (n - 1)); NaN if J is rank deficient.
    """
    jac = np.asarray(jac, float)
    p = jac.shape[1]
    A = _pseudo_inverse(jac)
    if A is None:
        return np.full((p, p), np.nan)
    shape = influence.mean.shape[0], influence.mean.shape[2]
    half = A.shape[1] // 2
    G = influence.project(A[:, :half].reshape((p,) + shape), A[:, half:].reshape((p,) + shape))
    n = influence.n
    return G @ G.T / (n * (n - 1.0))


@dataclass(frozen=True)
class MisfitReference:
    """Distribution of the misfit Q = sum r^2 at the optimum under the fitted model (sampling
    error only), matched to a chi2_nu (Satterthwaite).

    Attributes
    ----------
    expected : float
        E[Q] = trace((I - H) Cov(eps)), exact.
    variance : float
        Var[Q] from the multiplier bootstrap.
    scale, dof : float
        a and nu of Q ~ a chi2_nu (a nu = expected, 2 a^2 nu = variance).
    level : float
        Quantile of the threshold.
    threshold : float
        a chi2_nu.ppf(level).
    """

    expected: float
    variance: float
    scale: float
    dof: float
    level: float
    threshold: float

    def p_value(self, misfit: float) -> float:
        """P(Q >= misfit) under the fitted model."""
        return float(special.chdtrc(self.dof, max(misfit / self.scale, 0.0)))  # scipy.stats.chi2.sf, without importing scipy.stats (~1 s a process)


def misfit_reference(jac, influence: RunInfluence, rng: np.random.Generator, draws: int = 200, level: float = 0.99) -> MisfitReference:
    """Reference distribution of the cost (5.25) at the optimum if the model is right.

    Parameters
    ----------
    jac : ndarray, shape (2 n_states T, p)
        Jacobian of the weighted residuals at the estimate.
    influence : RunInfluence
    rng : numpy.random.Generator
        Source of the multiplier bootstrap's N(0, 1) weights (one per realisation and draw).
    draws : int
        Multiplier-bootstrap draws for Var[Q] (200: the variance to ~10 %, the 99 % quantile
        of the matched chi-square to a few per cent).
    level : float
        Quantile of the threshold.

    Returns
    -------
    MisfitReference
    """
    jac = np.asarray(jac, float)
    n = influence.n
    norm = 1.0 / np.sqrt(n * (n - 1.0))  # eps = F g / sqrt(n (n - 1)), g ~ N(0, I): Cov(eps) = F F' / (n (n - 1))
    q, r = np.linalg.qr(jac)
    keep = np.abs(np.diag(r)) > 1e-12 * max(np.abs(np.diag(r)).max(initial=0.0), 1e-300)
    q = q[:, keep]  # orthonormal basis of the columns of J: H = q q'
    shape = influence.mean.shape[0], influence.mean.shape[2]
    half = q.shape[0] // 2
    QF = influence.project(q[:half].T.reshape((-1,) + shape), q[half:].T.reshape((-1,) + shape)) * norm  # (k, n)
    total = (np.sum(influence.mean**2) + np.sum(influence.std**2)) * norm**2
    expected = float(total - np.sum(QF**2))
    g = rng.standard_normal((n, draws))
    eps_m = np.einsum("snt,nb->bst", influence.mean, g, optimize=True)
    eps_s = np.einsum("snt,nb->bst", influence.std, g, optimize=True)
    Q = (np.sum(eps_m**2, axis=(1, 2)) + np.sum(eps_s**2, axis=(1, 2))) * norm**2 - np.sum((QF @ g) ** 2, axis=0)
    variance = float(np.var(Q, ddof=1))
    if not (expected > 0 and variance > 0):
        return MisfitReference(expected, variance, float("nan"), float("nan"), level, float("nan"))
    scale = variance / (2.0 * expected)
    dof = expected / scale
    return MisfitReference(expected, variance, scale, dof, level, float(scale * 2.0 * special.gammaincinv(dof / 2.0, level)))  # scale * scipy.stats.chi2.ppf(level, dof)


def sampling_errors(jac, influence: RunInfluence, theta, at_zero, rng: np.random.Generator):
    """Standard errors, one-sided bounds of stds at zero and the misfit's reference of a fit.

    A std estimated at the lower bound of its box is a boundary estimate: the moments depend on
    sigma^2, so its column of the Jacobian is taken in v = sigma^2 (d r / d v = d r / d sigma /
    (2 sigma), finite as sigma -> 0), and its one-sided 95 % upper bound is sqrt(v + 1.645 se(v)).

    Parameters
    ----------
    jac : ndarray, shape (2 n_states T, p)
        Jacobian of the weighted residuals at the estimate (copied, not changed).
    influence : RunInfluence
    theta : ndarray, shape (p,)
        The estimate.
    at_zero : sequence of int
        Indices of the stds at the lower bound of their box.
    rng : numpy.random.Generator

    Returns
    -------
    se : ndarray, shape (p,)
        Sandwich standard errors (NaN at ``at_zero`` and where J is rank deficient).
    upper : dict
        index -> one-sided 95 % upper bound of each std at zero.
    reference : MisfitReference
    """
    jac = np.array(jac, float)
    theta = np.asarray(theta, float)
    zero = list(at_zero)
    for i in zero:
        jac[:, i] /= 2.0 * max(abs(theta[i]), 1e-300)
    cov = sandwich_covariance(jac, influence)
    se = np.sqrt(np.clip(np.diag(cov), 0.0, None)) if np.all(np.isfinite(cov)) else np.full(theta.size, np.nan)
    upper = {i: float(np.sqrt(theta[i] ** 2 + 1.6448536269514722 * se[i])) for i in zero}
    se[zero] = np.nan
    return se, upper, misfit_reference(jac, influence, rng)


def gauss_newton_errors(residuals, jacobian) -> np.ndarray:
    """Gauss-Newton standard errors sqrt(diag(s^2 (J'J)^-1)), s^2 = r'r / (m - p): the residuals
    taken as independent with one variance (NaN where J'J is singular).

    Parameters
    ----------
    residuals : ndarray, shape (m,)
        Weighted residuals at the optimum.
    jacobian : ndarray, shape (m, p)
        Their derivative with respect to the p parameters.

    Returns
    -------
    ndarray, shape (p,)
        Standard errors in the parameters' units.
    """
    dof = max(residuals.size - jacobian.shape[1], 1)
    s2 = residuals @ residuals / dof
    try:
        cov = s2 * np.linalg.inv(jacobian.T @ jacobian)
    except np.linalg.LinAlgError:
        return np.full(jacobian.shape[1], np.nan)
    return np.sqrt(np.clip(np.diag(cov), 0.0, None))

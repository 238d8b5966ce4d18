"""emcee cross-check of the identified distributions: a log-posterior over the six distribution
parameters with a whitened, time-aggregated likelihood of the measured mean and std, and
sampling by several independent emcee ensembles with autocorrelation-based stopping and R-hat.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, Mapping

import emcee
import numpy as np
import xarray as xr

__all__ = ["MOVES", "MomentLikelihood", "BoxPrior", "log_posterior", "sample_ensembles", "gelman_rubin", "chain_dataset"]


def _stretch():
    """emcee's default affine-invariant stretch move (Goodman & Weare 2010)."""
    return None


def _differential_evolution():
    """Differential-evolution proposals with a snooker share, the mix emcee's documentation
    suggests for correlated posteriors; fewer steps per independent sample here than stretch."""
    return [(emcee.moves.DEMove(), 0.8), (emcee.moves.DESnookerMove(), 0.2)]


#: Registry of emcee proposal schemes; config strings (``bayes.moves``) select them.
MOVES: dict[str, Callable] = {"stretch": _stretch, "de": _differential_evolution}


@dataclass
class MomentLikelihood:
    """Gaussian likelihood of the measured mean and std at K aggregated times, whitened.

    The measured mean and std are estimates from N realisations; their joint sampling
    covariance across times and states is estimated from the realisations themselves by the
    delta method (a, b run over state-time pairs, z = x - mean): Cov(m_a, m_b) = C_ab / N,
    Cov(m_a, s_b) = E[z_a z_b^2] / (2 s_b N) and Cov(s_a, s_b) = (E[z_a^2 z_b^2] - C_aa C_bb) /
    (4 s_a s_b N). For Gaussian states the last is the textbook C_ab^2 / (2 s_a s_b N), i.e.
    sigma / sqrt(2 N) for one std; the states here are not Gaussian (the uniform wind, products
    of normal parameters), and the fourth moments say by how much. Consecutive times are strongly
    correlated, so pretending independence would overstate the information many-fold; the
    likelihood uses K well-separated times and the full covariance (whitening by its Cholesky
    factor). A floor of ``model_error`` times each state's largest std is added in quadrature
    to both blocks for the PCE truncation (about 1 % at N_PCE = 2, see the convergence figure);
    ``noise_variance`` (per state) is added to the model variance for noisy data (5.6).
    The covariance is itself estimated from the N realisations, and the inverse of an estimated
    p x p covariance overstates the precision by (N - 1) / (N - p - 2) (Hartlap, Simon &
    Schneider 2007, A&A 464, 399); ``precision_factor`` undoes that (~0.87 for p = 264, N = 2000).
    """

    mean: np.ndarray  # (4, K)
    std: np.ndarray  # (4, K)
    chol: np.ndarray  # (8K, 8K) lower Cholesky factor of the covariance of [mean, std]
    noise_variance: np.ndarray | None = None
    precision_factor: float = 1.0

    @classmethod
    def from_samples(cls, x, model_error: float = 0.01, noise_variance=None) -> "MomentLikelihood":
        """x : ndarray, shape (4, N, K): the realisations at the K likelihood times."""
        x = np.asarray(x, float)
        d, N, K = x.shape
        flat = x.transpose(1, 0, 2).reshape(N, d * K)
        m, s = flat.mean(axis=0), flat.std(axis=0, ddof=1)
        z = flat - m
        joint = np.cov(np.concatenate([z, z**2], axis=1), rowvar=False) / N  # of (mean, variance) estimates
        n = d * K
        to_std = np.concatenate([np.ones(n), 0.5 / s])  # d std = d var / (2 s)
        cov = joint * np.outer(to_std, to_std)
        floor = (model_error * np.repeat(s.reshape(d, K).max(axis=1), K)) ** 2
        cov += np.diag(np.concatenate([floor, floor]))
        cov += 1e-12 * np.trace(cov) / cov.shape[0] * np.eye(cov.shape[0])
        p = 2 * n
        if N <= p + 2:
            raise ValueError(f"{N} realisations cannot estimate the {p} x {p} covariance of {K} likelihood times; "
                             f"need more than {p + 2} (raise bayes.likelihood_dt or the sample count)")
        return cls(m.reshape(d, K), s.reshape(d, K), np.linalg.cholesky(cov), None if noise_variance is None else np.asarray(noise_variance, float),
                   (N - p - 2) / (N - 1))

    def __call__(self, model_mean, model_variance) -> float:
        var = model_variance if self.noise_variance is None else model_variance + self.noise_variance[:, None]
        r = np.concatenate([(model_mean - self.mean).ravel(), (np.sqrt(np.maximum(var, 0.0)) - self.std).ravel()])
        z = _forward(self.chol, r)
        return -0.5 * self.precision_factor * float(z @ z)


def _forward(L, r):
    from scipy.linalg import solve_triangular

    return solve_triangular(L, r, lower=True, check_finite=False)


@dataclass(frozen=True)
class BoxPrior:
    """Uniform prior on a box, with low < high for the uniform mean wind (indices 4, 5)."""

    low: np.ndarray
    high: np.ndarray

    @classmethod
    def from_config(cls, config: Mapping[str, Any]) -> "BoxPrior":
        b = config["bayes"]["prior"]
        names = ("mu_mean", "mu_std", "l_f_mean", "l_f_std", "F_w_mean_low", "F_w_mean_high")
        return cls(np.array([b[n][0] for n in names], float), np.array([b[n][1] for n in names], float))

    def __call__(self, theta) -> float:
        theta = np.asarray(theta)
        if np.any(theta <= self.low) or np.any(theta >= self.high) or theta[4] >= theta[5]:
            return -np.inf
        return 0.0


def log_posterior(theta, model, likelihood: MomentLikelihood, prior: BoxPrior, index) -> float:
    """log prior + log likelihood; -inf outside the prior or where the model is not physical."""
    lp = prior(theta)
    if not np.isfinite(lp):
        return -np.inf
    try:
        r = model.moments(theta)
    except ValueError:
        return -np.inf
    return lp + likelihood(r.mean[:, index], r.variance[:, index])


def gelman_rubin(chains) -> np.ndarray:
    """Split-free R-hat between chains; chains (m, n, p) -> (p,). Each chain is one ensemble's
    pooled, thinned samples, so R-hat compares ensembles, never walkers of one ensemble."""
    chains = np.asarray(chains, float)
    m, n, _ = chains.shape
    means = chains.mean(axis=1)
    W = chains.var(axis=1, ddof=1).mean(axis=0)
    B = n * means.var(axis=0, ddof=1)
    var = (n - 1) / n * W + B / n
    return np.sqrt(var / W)


def sample_ensembles(log_prob: Callable, starts, walkers: int, rng: np.random.Generator, max_steps: int,
                     check_every: int = 500, tau_factor: float = 50.0, ball: float = 1e-3, progress: bool = False,
                     burn_in: int = 0, moves: str = "stretch"):
    """Run one emcee ensemble per start until N > tau_factor * tau (or max_steps).

    Parameters
    ----------
    starts : sequence of ndarray, shape (p,)
        Centre of each ensemble's initial ball (relative radius ``ball``).
    burn_in : int
        Steps run first and discarded (``sampler.reset()``): the walkers grow out of the small
        ball before tau is measured, so the transient does not inflate it.
    moves : {"stretch", "de"}
        Proposal scheme, see :data:`MOVES`.

    Returns
    -------
    list of dict with "chain" (steps, walkers, p) after the burn-in, "log_prob" (steps, walkers),
    "tau" (p,), "converged" (bool), "burn", "thin", "acceptance", "burn_in".
    """
    if moves not in MOVES:
        raise ValueError(f"unknown emcee moves '{moves}'; choose one of {', '.join(MOVES)}")
    out = []
    for centre in starts:
        centre = np.asarray(centre, float)
        p0 = centre * (1.0 + ball * rng.standard_normal((walkers, centre.size)))
        sampler = emcee.EnsembleSampler(walkers, centre.size, log_prob, moves=MOVES[moves]())
        sampler.random_state = np.random.RandomState(int(rng.integers(2**31))).get_state()
        state, tau, converged = p0, np.full(centre.size, np.inf), False
        if burn_in > 0:
            # emcee's condition-number check misfires on a small ball when the parameters have
            # very different scales (0.1 for mu's std, 500 N for the wind); the ball is its own advice.
            state = sampler.run_mcmc(state, burn_in, progress=progress, skip_initial_state_check=True)
            sampler.reset()
        while sampler.iteration < max_steps:
            state = sampler.run_mcmc(state, check_every, progress=progress, skip_initial_state_check=True)
            tau = sampler.get_autocorr_time(tol=0)
            if np.all(np.isfinite(tau)) and sampler.iteration > tau_factor * tau.max():
                converged = True
                break
        burn = int(2 * np.nanmax(tau)) if np.all(np.isfinite(tau)) else sampler.iteration // 2
        thin = max(1, int(0.5 * np.nanmin(tau))) if np.all(np.isfinite(tau)) else 1
        out.append({"chain": sampler.get_chain(), "log_prob": sampler.get_log_prob(), "tau": tau, "converged": converged,
                    "burn": min(burn, sampler.iteration - 1), "thin": thin, "acceptance": float(np.mean(sampler.acceptance_fraction)),
                    "burn_in": int(burn_in)})
    return out


def chain_dataset(runs, names, attrs: Mapping[str, Any]) -> xr.Dataset:
    """Chains of all ensembles as a dataset (ensemble, step, walker, parameter), NaN-padded."""
    steps = max(r["chain"].shape[0] for r in runs)
    walkers, p = runs[0]["chain"].shape[1:]
    chain = np.full((len(runs), steps, walkers, p), np.nan)
    logp = np.full((len(runs), steps, walkers), np.nan)
    for i, r in enumerate(runs):
        chain[i, : r["chain"].shape[0]] = r["chain"]
        logp[i, : r["log_prob"].shape[0]] = r["log_prob"]
    pooled = [r["chain"][r["burn"] :: r["thin"]].reshape(-1, p) for r in runs]
    n = min(len(x) for x in pooled)
    rhat = gelman_rubin(np.stack([x[-n:] for x in pooled])) if n > 1 else np.full(p, np.nan)
    tau = np.array([r["tau"] for r in runs])
    ess = np.array([(r["chain"].shape[0] - r["burn"]) * walkers / r["tau"] for r in runs]).sum(axis=0)
    return xr.Dataset(
        {
            "chain": (("ensemble", "step", "walker", "parameter"), chain),
            "log_prob": (("ensemble", "step", "walker"), logp),
            "tau": (("ensemble", "parameter"), tau),
            "burn": ("ensemble", [r["burn"] for r in runs]),
            "thin": ("ensemble", [r["thin"] for r in runs]),
            "converged": ("ensemble", np.array([r["converged"] for r in runs], np.int8)),
            "acceptance": ("ensemble", [r["acceptance"] for r in runs]),
            "burn_in": ("ensemble", [r.get("burn_in", 0) for r in runs], {"long_name": "steps discarded before the stored chain"}),
            "r_hat": ("parameter", rhat, {"long_name": "Gelman-Rubin R-hat between ensembles"}),
            "ess": ("parameter", ess, {"long_name": "effective sample size, sum over ensembles"}),
        },
        coords={"parameter": list(names)},
        attrs=dict(attrs),
    )

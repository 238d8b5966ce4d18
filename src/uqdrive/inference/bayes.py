"""emcee cross-check of the identified distributions: a log-posterior over the six distribution
parameters with a whitened, time-aggregated likelihood of the measured mean and std, and
sampling by several independent emcee ensembles with autocorrelation-based stopping and R-hat.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass
from typing import Any, Callable, Mapping, Sequence

import numpy as np
import xarray as xr

from ..numerics.threads import with_single_blas_thread
from ..settings import Settings

__all__ = ["MOVES", "MomentLikelihood", "BoxPrior", "log_posterior", "log_posteriors", "log_posterior_batch", "sample_ensembles",
           "gelman_rubin", "chain_dataset"]


def _stretch():
    """emcee's default affine-invariant stretch move (Goodman & Weare 2010)."""
    return None


def _differential_evolution():
    """Differential-evolution proposals with a snooker share, the mix emcee's documentation
    suggests for correlated posteriors; fewer steps per independent sample here than stretch."""
    import emcee

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

    def batch(self, model_mean, model_variance) -> np.ndarray:
        """Log-likelihoods of B model moments at once, (B, 4, K) each -> (B,): one triangular
        solve with B right-hand sides, otherwise the arithmetic of ``__call__``."""
        var = model_variance if self.noise_variance is None else model_variance + self.noise_variance[:, None]
        B = model_mean.shape[0]
        r = np.concatenate([(model_mean - self.mean).reshape(B, -1), (np.sqrt(np.maximum(var, 0.0)) - self.std).reshape(B, -1)], axis=1)
        z = _forward(self.chol, r.T)  # (8K, B)
        return -0.5 * self.precision_factor * np.einsum("ij,ij->j", z, z)


def _forward(L, r):
    from scipy.linalg import solve_triangular

    return solve_triangular(L, r, lower=True, check_finite=False)


@dataclass(frozen=True)
class BoxPrior:
    """Uniform prior on a box, with low < high for the uniform mean wind (indices 4, 5)."""

    low: np.ndarray
    high: np.ndarray

    @classmethod
    def from_settings(cls, settings: Settings) -> "BoxPrior":
        """The box of the settings' ``bayes_prior`` (low, high per parameter, in ``theta_names`` order)."""
        b = settings.bayes_prior
        if not b:
            raise KeyError("the config lacks bayes.prior (low, high of each distribution parameter)")
        return cls(np.array([lo for lo, _ in b], float), np.array([hi for _, hi in b], float))

    def __call__(self, theta) -> float:
        theta = np.asarray(theta)
        if np.any(theta <= self.low) or np.any(theta >= self.high) or theta[4] >= theta[5]:
            return -np.inf
        return 0.0

    def inside(self, thetas) -> np.ndarray:
        """thetas (B, p) -> bool (B,): where ``__call__`` is 0 (not -inf)."""
        thetas = np.asarray(thetas)
        return np.all(thetas > self.low, axis=1) & np.all(thetas < self.high, axis=1) & (thetas[:, 4] < thetas[:, 5])


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


@with_single_blas_thread
def log_posteriors(model, requests: Sequence, every: int = 1) -> list[np.ndarray]:
    """Log-posteriors of several targets that share one model, all proposals in one model call.

    Parameters
    ----------
    model
        Has ``moments_batch(thetas, every)`` (e.g. :class:`uqdrive.vehicle.chaos.LSTChaosModel`).
    requests : sequence of (thetas, likelihood, prior, index)
        thetas (n_i, p); a :class:`MomentLikelihood` and a :class:`BoxPrior`; ``index`` the
        likelihood times on the model grid observed every ``every`` samples.
    every : int
        Passed to ``moments_batch``: only the times the likelihoods read are computed.

    Returns
    -------
    list of ndarray, shape (n_i,)
        log prior + log likelihood, -inf outside the prior or where the model is not physical
        (as :func:`log_posterior` per theta). Runs with one BLAS thread (small matrices).
    """
    thetas = [np.atleast_2d(np.asarray(t, float)) for t, *_ in requests]
    inside = [prior.inside(t) for t, (_, _, prior, _) in zip(thetas, requests)]
    out = [np.full(t.shape[0], -np.inf) for t in thetas]
    stacked = np.concatenate([t[ok] for t, ok in zip(thetas, inside)])
    if stacked.shape[0] == 0:
        return out
    m = model.moments_batch(stacked, every=every)
    start = 0
    for (_, like, _, index), ok, lp in zip(requests, inside, out):
        stop = start + int(ok.sum())
        good = m.admissible[start:stop]
        values = np.full(stop - start, -np.inf)
        if good.any():
            values[good] = like.batch(m.mean[start:stop][good][..., index], m.variance[start:stop][good][..., index])
        lp[ok] = values
        start = stop
    return out


def log_posterior_batch(thetas, model, likelihood: MomentLikelihood, prior: BoxPrior, index, every: int = 1) -> np.ndarray:
    """:func:`log_posterior` of B parameter vectors (B, p) -> (B,) in one batched model call;
    ``index`` on the model grid observed every ``every`` samples."""
    return log_posteriors(model, [(thetas, likelihood, prior, index)], every)[0]


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


class _Lockstep:
    """Gathers the log-probability calls of samplers that run in threads into one call.

    Each active sampler blocks in :meth:`request` until every active sampler has a call
    pending; the last to arrive evaluates them all at once, in the samplers' order, and wakes
    the others. A batch thus holds one call per active sampler in a fixed order, whatever the
    thread timing, so the batches, and the chains, are reproducible.
    """

    def __init__(self, evaluate: Callable, n: int):
        self._evaluate, self._active = evaluate, n
        self._pending: dict = {}
        self._done: dict = {}
        self._cv = threading.Condition()

    def request(self, key, thetas):
        with self._cv:
            self._pending[key] = thetas
            self._flush_if_complete()
            while key not in self._done:
                self._cv.wait()
            out = self._done.pop(key)
        if isinstance(out, BaseException):
            raise out
        return out

    def leave(self):
        """A sampler has finished: the others no longer wait for it."""
        with self._cv:
            self._active -= 1
            self._flush_if_complete()

    def _flush_if_complete(self):
        if not self._pending or len(self._pending) < self._active:
            return
        batch, self._pending = dict(sorted(self._pending.items())), {}  # in sampler order, not arrival order
        try:
            results = self._evaluate(list(batch.items()))
        except Exception as error:  # every waiting sampler raises it
            results = [error] * len(batch)
        self._done.update(zip(batch, results))
        self._cv.notify_all()


def sample_ensembles(log_prob: Callable, starts, walkers: int, rng: np.random.Generator, max_steps: int,
                     check_every: int = 500, tau_factor: float = 50.0, ball: float = 1e-3, progress: bool = False,
                     burn_in: int = 0, moves: str = "stretch", vectorize: bool = False, lockstep: bool = False,
                     log: Callable[[str], None] | None = None):
    """Run one emcee ensemble per start until N > tau_factor * tau (or max_steps).

    Parameters
    ----------
    log_prob : callable
        theta (p,) -> float; with ``vectorize``, the proposals of the walkers being moved
        (n, p) -> (n,) (emcee's ``vectorize=True``: one call per half-ensemble update); with
        ``lockstep``, a list of (ensemble index, thetas (n, p)) -> a list of (n,) arrays.
    starts : sequence of ndarray, shape (p,)
        Centre of each ensemble's initial ball (relative radius ``ball``).
    burn_in : int
        Steps run first and discarded (``sampler.reset()``): the walkers grow out of the small
        ball before tau is measured, so the transient does not inflate it.
    moves : {"stretch", "de"}
        Proposal scheme, see :data:`MOVES`.
    vectorize : bool
        ``log_prob`` takes all proposals of a half-ensemble update at once (see above).
    lockstep : bool
        Run the ensembles concurrently, one thread each, and evaluate the pending proposals of
        all of them in one ``log_prob`` call (e.g. one batched model evaluation for 4 x 6
        walkers). Each ensemble keeps its own random state, proposals and stopping, so its
        chain is the one it has when run alone (to the rounding of the batched arithmetic).
    log : callable, optional
        Receives a progress line at every convergence check.

    Returns
    -------
    list of dict with "chain" (steps, walkers, p) after the burn-in, "log_prob" (steps, walkers),
    "tau" (p,), "converged" (bool), "burn", "thin", "acceptance", "burn_in".
    """
    if moves not in MOVES:
        raise ValueError(f"unknown emcee moves '{moves}'; choose one of {', '.join(MOVES)}")
    import emcee  # here, not at the top: emcee loads scipy.stats, ~0.8 s of every job's start

    initial = []
    for centre in starts:  # the draws of the sequential loop, in its order
        centre = np.asarray(centre, float)
        initial.append((centre * (1.0 + ball * rng.standard_normal((walkers, centre.size))), int(rng.integers(2**31))))

    def run(i, fn):
        p0, seed = initial[i]
        sampler = emcee.EnsembleSampler(walkers, p0.shape[1], fn, moves=MOVES[moves](), vectorize=vectorize or lockstep)
        sampler.random_state = np.random.RandomState(seed).get_state()
        state, tau, converged = p0, np.full(p0.shape[1], np.inf), False
        if burn_in > 0:
            # emcee's condition-number check misfires on a small ball when the parameters have
            # very different scales (0.1 for mu's std, 500 N for the wind); the ball is its own advice.
            state = sampler.run_mcmc(state, burn_in, progress=progress, skip_initial_state_check=True)
            sampler.reset()
        while sampler.iteration < max_steps:
            state = sampler.run_mcmc(state, check_every, progress=progress, skip_initial_state_check=True)
            tau = sampler.get_autocorr_time(tol=0)
            converged = bool(np.all(np.isfinite(tau)) and sampler.iteration > tau_factor * tau.max())
            if log is not None:
                log(f"ensemble {i}: {sampler.iteration} steps after burn-in, tau max {np.nanmax(tau):.1f}"
                    f"{', converged' if converged else ''}")
            if converged:
                break
        burn = int(2 * np.nanmax(tau)) if np.all(np.isfinite(tau)) else sampler.iteration // 2
        thin = max(1, int(0.5 * np.nanmin(tau))) if np.all(np.isfinite(tau)) else 1
        return {"chain": sampler.get_chain(), "log_prob": sampler.get_log_prob(), "tau": tau, "converged": converged,
                "burn": min(burn, sampler.iteration - 1), "thin": thin, "acceptance": float(np.mean(sampler.acceptance_fraction)),
                "burn_in": int(burn_in)}

    if not lockstep:
        return [run(i, log_prob) for i in range(len(initial))]
    batcher = _Lockstep(log_prob, len(initial))
    out, errors = [None] * len(initial), []

    def worker(i):
        try:
            out[i] = run(i, lambda thetas: batcher.request(i, thetas))
        except BaseException as error:  # re-raised below, in the caller's thread
            errors.append(error)
        finally:
            batcher.leave()

    threads = [threading.Thread(target=worker, args=(i,), name=f"emcee-ensemble-{i}", daemon=True) for i in range(len(initial))]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    if errors:
        raise errors[0]
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

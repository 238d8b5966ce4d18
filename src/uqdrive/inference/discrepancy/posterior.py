"""emcee posterior of an augmented model's parameters (mu, l_f, mean wind and the named effect's)
given a measured ensemble (past the thesis).

Each evaluation of an augmented model is a common-random-numbers ensemble (a batched RK4 pass for
the Magic-Formula tyre, 0.3-1 s), too slow for the ~10^5 evaluations of emcee. The sampler runs on
a quadratic response surface of the moment map instead, built where the posterior lives:

1. Laplace approximation at the StructureFit optimum (its Jacobian, whitened by the likelihood's
   covariance) gives centre and covariance; whitened coordinates u = L^-1 (x - x_hat).
2. A Latin-hypercube design of standard-normal points times ``spread`` in u (clipped to the
   bounds), all evaluated with the full model in batched CRN passes (:meth:`StructureFit.statistics_many`).
3. A full quadratic in u per statistic (least squares) is the surrogate; with the germs fixed the
   moment map is smooth, so a quadratic is accurate over a few posterior widths.
4. emcee (vectorised over walkers, moves ``de``, several ensembles, R-hat between them, stopping at
   N > tau_factor * tau as :mod:`uqdrive.inference.bayes`) samples the surrogate posterior.
5. Validation: the full model at ``validate`` posterior draws. The error log L(full) -
   log L(surrogate) matters only as far as it moves the posterior: its first-order shift of each
   parameter's mean and standard deviation (:func:`~uqdrive.inference.surrogate.first_order_shift`,
   in posterior sd) must stay within ``tolerance``. (The spread of the error itself, reported as
   ``loglik_spread``, is no criterion: it is heavy-tailed, a few draws at the posterior's edge
   where the full model fits by units of log-likelihood better than the quadratic, so its
   standard deviation over a few dozen draws swings far more than the summaries it would
   guard.) When the check fails, the design is rebuilt around the posterior's mean and
   covariance (earlier evaluations inside it, the validation draws above all, are kept) and
   emcee rerun.

Likelihood: the project's whitened moment likelihood (:class:`uqdrive.inference.bayes.MomentLikelihood`)
at ``times`` well-separated times, not the StructureFit's null-band residuals: those are strongly
correlated in time (the band's ``inflation``, Var(sum z) / sum Var(z), is ~10 on the slalom), so
sum z^2 is no log-likelihood, and a scalar tempering is right for one direction only. The moment
likelihood whitens by the full covariance of [mean, std] over states and times, estimated from the
data's own realisations (fourth moments included), with the Hartlap factor for an estimated
covariance. The CRN model's moments carry their own sampling error (M realisations, independent of
the data's n), so the covariance is multiplied by 1 + n / M. A floor of ``model_error`` times each
state's largest std is added in quadrature (as ``bayes.model_error``): realisations of a few germs
span a nearly singular covariance (condition ~1e14 without noise), and tiny structural differences
along its null directions made the posterior far too narrow without the floor (rms z-score of the
truth 3-40 instead of 1 on model-generated data; 0.7-1.4 with a floor of 1 %).
"""

from __future__ import annotations

import time as _time

import numpy as np
from scipy.linalg import solve_triangular

from ..bayes import MOVES, MomentLikelihood, chain_dataset
from ..parallel import fork_map
from ..surrogate import first_order_shift, fit_quadratic, gaussian_design, quadratic_features
from .fit import StructureFit

__all__ = ["quadratic_features", "fit_quadratic", "gaussian_design", "first_order_shift", "likelihood_times", "sample_vectorised", "AugmentedPosterior"]


def likelihood_times(K: int, n: int, max_times: int, channels: int = 4):
    """Evenly spaced indices into K compared times for the whitened likelihood: at most
    ``max_times`` and at most (n - 2) / (4 C), so the 2 C k-dimensional covariance of [mean, std]
    (C measured channels, 4 states by default) is estimated from n realisations with the Hartlap
    factor >= 1/2.

    Returns
    -------
    ndarray of int, shape (k,)
    """
    k = int(max(1, min(K, max_times, (n - 2) // (4 * channels))))
    return np.unique(np.round(np.linspace(K / k - 1.0, K - 1.0, k)).astype(int))


def sample_vectorised(log_prob, starts, rng: np.random.Generator, max_steps: int, check_every: int = 500, tau_factor: float = 50.0,
                      burn_in: int = 0, moves: str = "de", jobs: int = 1):
    """One emcee ensemble per start, ``log_prob`` vectorised over walkers (emcee ``vectorize``);
    stopping, burn and thinning as :func:`uqdrive.inference.bayes.sample_ensembles`.

    Parameters
    ----------
    log_prob : callable
        (B, p) -> (B,) log posterior (-inf outside the prior).
    starts : sequence of ndarray, shape (walkers, p)
        Initial walkers of each ensemble.
    jobs : int
        Worker processes for the ensembles (:func:`uqdrive.inference.parallel.fork_map`); each
        ensemble's seed is drawn from ``rng`` first, in order, so every count gives the same chains.

    Returns
    -------
    list of dict
        "chain" (steps, walkers, p), "log_prob", "tau" (p,), "converged", "burn", "thin",
        "acceptance", "burn_in" (the format :func:`uqdrive.inference.bayes.chain_dataset` reads).
    """
    import emcee  # noqa: F401  (loaded before the workers fork, which would each load it anew)

    seeds = [int(rng.integers(2**31)) for _ in starts]
    return fork_map(lambda item: _ensemble(log_prob, *item, max_steps, check_every, tau_factor, burn_in, moves),
                    list(zip(starts, seeds)), jobs)


def _ensemble(log_prob, p0, seed: int, max_steps: int, check_every: int, tau_factor: float, burn_in: int, moves: str) -> dict:
    """One ensemble of :func:`sample_vectorised` from walkers ``p0`` (walkers, p), emcee's moves seeded with ``seed``."""
    import emcee  # here, not at the top: emcee loads scipy.stats, ~0.8 s of every job's start

    walkers, p = p0.shape
    sampler = emcee.EnsembleSampler(walkers, p, log_prob, moves=MOVES[moves](), vectorize=True)
    sampler.random_state = np.random.RandomState(seed).get_state()
    state, tau, converged = p0, np.full(p, np.inf), False
    if burn_in > 0:
        state = sampler.run_mcmc(state, burn_in, skip_initial_state_check=True)
        sampler.reset()
    while sampler.iteration < max_steps:
        state = sampler.run_mcmc(state, min(check_every, max_steps - sampler.iteration), skip_initial_state_check=True)
        tau = sampler.get_autocorr_time(tol=0)
        if np.all(np.isfinite(tau)) and sampler.iteration > tau_factor * tau.max():
            converged = True
            break
    finite = np.all(np.isfinite(tau))
    burn = int(2 * np.nanmax(tau)) if finite else sampler.iteration // 2
    return {"chain": sampler.get_chain(), "log_prob": sampler.get_log_prob(), "tau": tau, "converged": converged,
            "burn": min(burn, sampler.iteration - 1), "thin": max(1, int(0.5 * np.nanmin(tau))) if finite else 1,
            "acceptance": float(np.mean(sampler.acceptance_fraction)), "burn_in": int(burn_in)}


class AugmentedPosterior:
    """Posterior of a fitted augmented model's parameters by emcee on a validated quadratic
    surrogate of the CRN moment map (see the module docstring for the design and the likelihood).

    Parameters
    ----------
    times : int
        Largest number of likelihood times (fewer for small ensembles, :func:`likelihood_times`).
    design : int, optional
        Full-model evaluations of the design (default: twice the quadratic's terms plus one).
    spread : float
        Standard deviation of the design in units of the Laplace (later: posterior) covariance.
    walkers, ensembles : int
        emcee walkers per ensemble (default max(3 p, 16)) and independent ensembles (R-hat).
    burn_in, max_steps, check_every, tau_factor : int, int, int, float
        As ``bayes.*`` of the config.
    moves : {"de", "stretch"}
    validate : int
        Posterior draws at which the full model checks the surrogate (the shifts' standard error
        is about spread(error) / sqrt(validate) posterior sd: 0.08 for 64 draws of the thesis case).
    tolerance : float
        Largest first-order shift of a parameter's posterior mean or standard deviation by the
        surrogate's error, in posterior standard deviations.
    rounds : int
        Design rounds at most (a failed validation triggers the next one).
    model_error : float
        Floor added to the likelihood's covariance, as a fraction of each state's largest std.
    batch : int
        Parameter sets per batched full-model pass.
    jobs : int
        Worker processes for the batches of the design and the validation, and for the emcee
        ensembles (:func:`uqdrive.inference.parallel.fork_map`: the numbers of one process).

    Attributes
    ----------
    names_ : tuple of str
        Parameter names: :data:`uqdrive.vehicle.augmented.THETA_NAMES`, then the effect's.
    samples_ : ndarray, shape (S, p)
        Pooled posterior samples (after burn-in and thinning) of all ensembles.
    mean_, low_, high_ : ndarray, shape (p,)
        Posterior mean and 2.5 / 97.5 % quantiles.
    r_hat_, tau_, ess_ : ndarray, shape (p,)
        R-hat between ensembles, largest autocorrelation time (steps), effective sample size.
    converged_ : bool
        Every ensemble ran N > tau_factor * tau steps.
    validation_ : dict
        ``shift`` (the largest first-order shift, the criterion), ``shifts`` (per parameter: mean,
        sd and their standard errors), ``loglik_spread`` (std of log L(full) - log L(surrogate)
        over the validation draws),
        ``max_whitened_error`` (largest |error| of a whitened statistic, in its standard errors),
        ``points``, ``passed``, ``rounds``, ``design_points`` (of the last round) and ``history``
        (per round: spread, design points, seconds since the start).
    laplace_sd_ : ndarray, shape (p,)
        Standard deviations of the Laplace approximation (the design's first scale).
    evaluations_ : int
        Full-model evaluations (design and validation).
    seconds_ : float
    """

    def __init__(self, times: int = 30, design: int | None = None, spread: float = 1.5, walkers: int | None = None, ensembles: int = 4,
                 burn_in: int = 300, max_steps: int = 4000, check_every: int = 500, tau_factor: float = 50.0, moves: str = "de",
                 validate: int = 64, tolerance: float = 0.5, rounds: int = 2, model_error: float = 0.01, batch: int = 32, jobs: int = 1):
        self.times, self.design, self.spread = int(times), design, float(spread)
        self.walkers, self.ensembles = walkers, int(ensembles)
        self.burn_in, self.max_steps, self.check_every, self.tau_factor = int(burn_in), int(max_steps), int(check_every), float(tau_factor)
        self.moves, self.validate, self.tolerance, self.rounds = moves, int(validate), float(tolerance), int(rounds)
        if self.validate < 3:
            raise ValueError(f"validate is the number of posterior draws that check the surrogate, at least 3; got {validate}")
        self.model_error, self.batch, self.jobs = float(model_error), int(batch), int(jobs)

    # -- pieces ---------------------------------------------------------------------------------
    def _statistics(self, fit: StructureFit, points, sel):
        """Full-model [mean, std] at the likelihood times, flattened as the likelihood's, (B, 8 k)."""
        pairs = [(pt[:6], fit.structure(pt[6:])) for pt in np.atleast_2d(points)]
        # on workers, batches of one size that fill every worker's rounds (a pass's numbers do not
        # depend on the pairs that share it: tests/test_discrepancy_posterior.py)
        rounds = -(-len(pairs) // (self.jobs * self.batch))
        size = self.batch if self.jobs == 1 else -(-len(pairs) // (self.jobs * rounds))
        batches = [pairs[start:start + size] for start in range(0, len(pairs), size)]
        parts = fork_map(lambda b: fit.statistics_many([a for a, _ in b], [s for _, s in b], self.batch)[..., sel], batches, self.jobs)
        stats = np.concatenate(parts)
        return stats.reshape(stats.shape[0], -1)

    def _whiten(self, r):
        """Whitened residuals L^-1 r for rows r (B, 8 k)."""
        return solve_triangular(self._chol, np.atleast_2d(r).T, lower=True, check_finite=False).T

    def _inside(self, X):
        X = np.atleast_2d(X)
        ok = np.all((X > self._lo) & (X < self._hi), axis=1)
        return ok & (X[:, 4] < X[:, 5])

    def _surrogate(self, U, Y):
        """Whitened surrogate: coefficients of L^-1 (y(u) - y_data) as a quadratic in u."""
        coef = fit_quadratic(U, Y - self._data)
        return solve_triangular(self._chol, coef.T, lower=True, check_finite=False).T  # (n_terms, 8 k)

    def log_prob(self, X):
        """Log posterior (uniform prior on the fit's bounds, wind low < high) on the surrogate.

        Parameters
        ----------
        X : ndarray, shape (B, p)

        Returns
        -------
        ndarray, shape (B,)
        """
        X = np.atleast_2d(X)
        out = np.full(X.shape[0], -np.inf)
        ok = self._inside(X)
        if ok.any():
            U = (X[ok] - self._centre) @ self._inv_factor.T
            w = quadratic_features(U) @ self._coef
            out[ok] = -0.5 * self._factor * np.sum(w**2, axis=1)
        return out

    def _loglik_full(self, Y):
        w = self._whiten(Y - self._data)
        return -0.5 * self._factor * np.sum(w**2, axis=1), w

    def _mode(self, fit: StructureFit, sel, centre, J, cov, steps: int = 3):
        """The moment likelihood's mode by chord Gauss-Newton steps with the fit's Jacobian J
        (the StructureFit optimum minimises another criterion): one full-model evaluation a step,
        a step halved while it does not raise the likelihood."""
        width = self._hi - self._lo
        current, (best, w) = centre, self._loglik_full(self._statistics(fit, centre, sel))
        self._mode_evaluations = 1
        Jw = self._whiten(J.T).T
        for _ in range(steps):
            step = -cov @ (self._factor * Jw.T @ w[0])
            for _ in range(4):
                trial = np.clip(current + step, self._lo + 1e-9 * width, self._hi - 1e-9 * width)
                value, w_trial = self._loglik_full(self._statistics(fit, trial, sel))
                self._mode_evaluations += 1
                if value[0] > best[0]:
                    break
                step = 0.5 * step
            else:
                break
            current, best, w = trial, value, w_trial
        return current

    def _starts(self, rng, p):
        """Each ensemble's walkers: the Laplace normal around the centre, every walker inside the
        prior and no two alike. The centre may sit on a bound (a spread fitted to 0, a parameter
        at its limit: the open prior excludes it), so it is moved inside by 1e-6 of the width;
        walkers still outside after the redraws are pulled towards it by halving their distance.
        (Walkers set onto one point would be equal, and emcee's DE snooker move divides by their
        distance: NaN.)"""
        walkers = int(self.walkers or max(3 * p, 16))
        width = self._hi - self._lo
        centre = np.clip(self._centre, self._lo + 1e-6 * width, self._hi - 1e-6 * width)
        starts = []
        for _ in range(self.ensembles):
            x = centre + rng.standard_normal((walkers, p)) @ self._factor_L.T
            for _ in range(100):  # redraw walkers outside the prior
                bad = ~self._inside(x)
                if not bad.any():
                    break
                x[bad] = centre + rng.standard_normal((int(bad.sum()), p)) @ self._factor_L.T
            for _ in range(60):
                bad = ~self._inside(x)
                if not bad.any():
                    break
                x[bad] = centre + 0.5 * (x[bad] - centre)
            starts.append(x)
        return starts

    # -- the estimator --------------------------------------------------------------------------
    def fit(self, fit: StructureFit, x, rng: np.random.Generator) -> "AugmentedPosterior":
        """Sample the posterior of ``fit``'s parameters given the measured realisations.

        Parameters
        ----------
        fit : StructureFit
            A fitted joint fit (``fit_theta`` True) on common random numbers; its optimum, Jacobian
            and scale start the design.
        x : ndarray, shape (C, n, T_out)
            Measured channels (those of ``fit.simulator``) of the realisations (spun ones already excluded) on the simulator's output grid, so
            that ``fit.index`` selects the compared times.
        rng : numpy.random.Generator
            Design, walkers' starts, emcee's moves and the validation draws.
        """
        clock = _time.perf_counter()
        if not fit.fit_theta:
            raise ValueError("the posterior needs a fit of the distributions (fit_theta=True)")
        x = np.asarray(x, float)
        n, M = x.shape[1], fit.simulator.germs.n
        K = fit.index.size
        sel = likelihood_times(K, n, self.times, x.shape[0])
        like = MomentLikelihood.from_samples(x[:, :, fit.index[sel]], self.model_error)
        self._chol = like.chol * np.sqrt(1.0 + n / M)
        self._factor = like.precision_factor
        self._data = np.concatenate([like.mean.ravel(), like.std.ravel()])
        self._lo, self._hi = fit.parameter_bounds
        names = tuple(fit.parameter_names)
        p = len(names)
        centre = np.concatenate([fit.theta_, fit.effect_values_])
        # Laplace approximation: d statistics / d parameters from the fit's Jacobian (z units)
        J = (fit.jacobian_.reshape(2, x.shape[0], K, p)[:, :, sel] * np.asarray(fit.scale_)[:, :, sel, None]).reshape(-1, p)
        Jw = self._whiten(J.T).T
        width = self._hi - self._lo
        info = self._factor * Jw.T @ Jw + np.diag((1e-3 / width) ** 2)
        cov = np.linalg.inv(info)
        self.laplace_sd_ = np.sqrt(np.diag(cov))
        centre = self._mode(fit, sel, centre, J, cov)
        n_terms = quadratic_features(np.zeros((1, p))).shape[1]
        n_design = int(self.design or 2 * n_terms + 1)
        from scipy.stats import chi2

        pool_X, pool_Y, history = np.zeros((0, p)), np.zeros((0, self._data.size)), []
        for round_ in range(1, self.rounds + 1):
            self._centre, self._factor_L = centre, np.linalg.cholesky(cov)
            self._inv_factor = np.linalg.inv(self._factor_L)
            # earlier exact evaluations inside this round's design region are kept (the previous
            # round's validation draws above all: they are where the posterior is)
            near = np.sum(((pool_X - centre) @ self._inv_factor.T) ** 2, axis=1) <= self.spread**2 * chi2.ppf(0.9, p)
            X = centre + gaussian_design(max(n_design - int(near.sum()), n_terms), p, self.spread, rng) @ self._factor_L.T
            X = np.clip(X, self._lo + 1e-9 * width, self._hi - 1e-9 * width)
            Y = self._statistics(fit, X, sel)
            X, Y = np.vstack([pool_X[near], X]), np.vstack([pool_Y[near], Y])
            self._coef = self._surrogate((X - centre) @ self._inv_factor.T, Y)
            runs = sample_vectorised(self.log_prob, self._starts(rng, p), rng, self.max_steps, self.check_every, self.tau_factor, self.burn_in,
                                     self.moves, self.jobs)
            ds = chain_dataset(runs, names, {})
            pooled = np.concatenate([r["chain"][r["burn"]::r["thin"]].reshape(-1, p) for r in runs])
            points = pooled[rng.choice(pooled.shape[0], size=min(self.validate, pooled.shape[0]), replace=False)]
            Y_val = self._statistics(fit, points, sel)
            pool_X, pool_Y = np.vstack([pool_X, X[int(near.sum()):], points]), np.vstack([pool_Y, Y[int(near.sum()):], Y_val])
            full, w_full = self._loglik_full(Y_val)
            w_sur = quadratic_features((points - centre) @ self._inv_factor.T) @ self._coef
            error = full - self.log_prob(points)
            spread = float(np.std(error, ddof=1))
            mean_shift, sd_shift, mean_se, sd_se = first_order_shift(points, error)
            shift = float(max(np.max(np.abs(mean_shift)), np.max(np.abs(sd_shift))))
            history.append({"shift": round(shift, 4), "loglik_spread": round(spread, 4), "design_points": int(X.shape[0]),
                            "seconds": round(_time.perf_counter() - clock, 1)})
            validation = {"shift": shift,
                          "shifts": {n: {"mean": round(float(a), 4), "mean_se": round(float(b), 4), "sd": round(float(c), 4), "sd_se": round(float(e), 4)}
                                     for n, a, b, c, e in zip(names, mean_shift, mean_se, sd_shift, sd_se)},
                          "loglik_spread": spread, "max_whitened_error": float(np.max(np.abs(w_full - w_sur))), "points": int(points.shape[0]),
                          "passed": bool(shift <= self.tolerance), "rounds": round_, "design_points": int(X.shape[0]), "history": history}
            if validation["passed"]:
                break
            centre, cov = pooled.mean(axis=0), np.cov(pooled, rowvar=False)
        self.names_ = names
        self.samples_ = pooled
        self.mean_ = pooled.mean(axis=0)
        self.low_, self.high_ = np.percentile(pooled, [2.5, 97.5], axis=0)
        self.r_hat_ = ds["r_hat"].values
        self.tau_ = np.nanmax(ds["tau"].values, axis=0)
        self.ess_ = ds["ess"].values
        self.converged_ = bool(np.all(ds["converged"].values))
        self.acceptance_ = float(np.mean(ds["acceptance"].values))
        self.validation_ = validation
        self.evaluations_ = self._mode_evaluations + pool_X.shape[0]
        self.likelihood_times_ = int(sel.size)
        self.model_ratio_ = n / M
        self.seconds_ = _time.perf_counter() - clock
        return self

    def summary(self) -> dict:
        """The verdict's ``posterior`` entry: {parameter: [mean, lo95, hi95]} plus diagnostics."""
        out = {name: [float(m), float(lo), float(hi)] for name, m, lo, hi in zip(self.names_, self.mean_, self.low_, self.high_)}
        out.update({
            "r_hat": {n: round(float(v), 4) for n, v in zip(self.names_, self.r_hat_)},
            "tau": {n: round(float(v), 1) for n, v in zip(self.names_, self.tau_)},
            "ess": {n: round(float(v), 0) for n, v in zip(self.names_, self.ess_)},
            "converged": self.converged_,
            "acceptance": round(self.acceptance_, 3),
            "samples": int(self.samples_.shape[0]),
            "surrogate": {k: (round(v, 4) if isinstance(v, float) else v) for k, v in self.validation_.items()},
            "model_evaluations": int(self.evaluations_),
            "likelihood": f"whitened moment likelihood (uqdrive.inference.bayes.MomentLikelihood) of [mean, std] at "
                          f"{self.likelihood_times_} times, covariance x (1 + n/M) = {1 + self.model_ratio_:.3g} for the "
                          f"CRN model's own sampling error, floor {self.model_error:g} x each state's largest std; "
                          "uniform prior on the fit's bounds; emcee on a validated quadratic surrogate of the moment map",
            "seconds": round(self.seconds_, 1),
        })
        return out

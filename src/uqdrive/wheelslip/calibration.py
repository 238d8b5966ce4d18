"""The GP paper's experiment and what goes past it: training data, GP fit and PID tuning, slope
calibration (maximum likelihood vs hyperparameters integrated out with emcee), closed loop.
"""

from __future__ import annotations

import time
from typing import Any, Callable, Mapping

import numpy as np

from ..numerics.threads import with_single_blas_thread
from .gp import ArcsineGP, arcsine_kernel, arcsine_kernel_grad_x, arcsine_kernel_grad_xx
from .quarter_car import QuarterCar, damping, friction_curve, friction_slope, pid_gains

__all__ = [
    "training_data",
    "fit_friction_gp",
    "binomial_interval",
    "slope_interval_ml",
    "slope_interval_mcmc",
    "calibration",
    "prior_calibration",
    "posterior_curves",
]

Z95 = 1.959963984540054  # scipy.stats.norm.ppf(0.975) (tests/test_wheelslip.py); scipy.stats loads where it is used


def training_data(car: QuarterCar, n: int, region, noise_std: float, rng: np.random.Generator):
    """n noisy observations of (27) with slips uniform in ``region``, plus mu(0) = 0 noise-free.

    Returns
    -------
    slip : ndarray, shape (n + 1,); mu : ndarray, shape (n + 1,); noise_free : bool array
    """
    slip = np.concatenate([[0.0], rng.uniform(region[0], region[1], n)])
    mu = friction_curve(slip, car.mu_H, car.k)
    mu[1:] += noise_std * rng.standard_normal(n)
    return slip, mu, np.arange(n + 1) == 0


def fit_friction_gp(car: QuarterCar, n: int, region, noise_std: float, restarts: int, rng: np.random.Generator):
    """Draw a training set and fit the arcsine GP to it; returns (gp, slip, mu)."""
    slip, mu, exact = training_data(car, n, region, noise_std, rng)
    return ArcsineGP(restarts=restarts, rng=rng).fit(slip, mu, noise_free=exact), slip, mu


def binomial_interval(successes: int, trials: int, level: float = 0.95):
    """Clopper-Pearson interval of a binomial proportion."""
    a = (1 - level) / 2
    from scipy.stats import beta as beta_dist

    lo = beta_dist.ppf(a, successes, trials - successes + 1) if successes > 0 else 0.0
    hi = beta_dist.ppf(1 - a, successes + 1, trials - successes) if successes < trials else 1.0
    return float(lo), float(hi)


def slope_interval_ml(gp: ArcsineGP, x: float):
    """Mean, std and 95 % interval of the slope at x with the ML hyperparameters."""
    m, v = gp.predict_slope(np.array([x]))
    s = np.sqrt(max(v[0], 0.0))
    return m[0], s, (m[0] - Z95 * s, m[0] + Z95 * s)


def _log_posterior(log_thetas, gp: ArcsineGP, prior_std: float):
    """Log posterior of log hyperparameters, shape (W, p) -> (W,): emcee's vectorised form."""
    return -gp.negative_log_likelihood(log_thetas) - 0.5 * np.sum((log_thetas / prior_std) ** 2, axis=-1)


def slope_interval_mcmc(gp: ArcsineGP, x: float, rng: np.random.Generator, walkers: int = 16, steps: int = 400, burn: int = 150, prior_std: float = 3.0, draws: int = 200):
    """Slope at x with the hyperparameters integrated out (the paper's suggested remedy).

    emcee samples log hyperparameters under a N(0, prior_std^2) prior per log parameter, started
    in a small ball around the ML point; the slope posterior is the mixture of the Gaussian slope
    posteriors over ``draws`` thinned samples, and its 95 % interval is read from the mixture's
    quantiles (by bisection on the mixture CDF).
    """
    ndim = gp.log_theta_.size
    p0 = gp.log_theta_ + 1e-3 * rng.standard_normal((walkers, ndim))
    import emcee
    from scipy.special import ndtr  # what scipy.stats.norm.cdf computes, without its ~50 us of argument handling

    sampler = emcee.EnsembleSampler(walkers, ndim, _log_posterior, args=(gp, prior_std), vectorize=True)
    # emcee draws its moves from a RandomState of its own: seed it from the caller's generator.
    sampler.random_state = np.random.RandomState(int(rng.integers(2**31))).get_state()
    sampler.run_mcmc(p0, steps, progress=False)
    chain = sampler.get_chain(discard=burn, flat=True)
    pick = chain[rng.choice(chain.shape[0], size=min(draws, chain.shape[0]), replace=False)]
    # each draw's slope posterior, as a GP refitted with the draw's hyperparameters would give it
    # (log(exp(.)) rounds the draw as such a GP's log hyperparameters are rounded)
    means, variances = gp.slope_posteriors(np.log(np.exp(pick)), x)
    stds = np.sqrt(np.maximum(variances, 1e-300))

    def cdf(q):
        return np.mean(ndtr((q - means) / stds))

    lo_b, hi_b = (means - 10 * stds).min(), (means + 10 * stds).max()
    bounds = []
    for target in (0.025, 0.975):
        lo, hi = lo_b, hi_b
        for _ in range(80):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if cdf(mid) < target else (lo, mid)
        bounds.append(0.5 * (lo + hi))
    total_var = np.mean(stds**2) + np.var(means)
    return float(means.mean()), float(np.sqrt(total_var)), tuple(bounds)


@with_single_blas_thread
def calibration(car: QuarterCar, n: int, sets: int, region, noise_std: float, restarts: int, rng: np.random.Generator, mcmc: Mapping[str, int] | None = None,
                log: Callable[[str], None] | None = None, log_every: int = 100):
    """How often the 95 % slope interval at lambda* contains the true slope 0.3882.

    Returns a dict with per-set interval bounds, the hit count and the Clopper-Pearson interval,
    for maximum likelihood and (if ``mcmc`` settings are given) for integrated hyperparameters.
    ``log`` receives a progress line every ``log_every`` training sets.
    """
    truth = float(friction_slope(car.lambda_star, car.mu_H, car.k))
    out = {"truth": truth, "ml": [], "mcmc": []}
    clock = time.perf_counter()
    for k in range(sets):
        gp, _, _ = fit_friction_gp(car, n, region, noise_std, restarts, rng)
        out["ml"].append(slope_interval_ml(gp, car.lambda_star)[2])
        if mcmc is not None and len(out["mcmc"]) < mcmc["sets"]:
            out["mcmc"].append(slope_interval_mcmc(gp, car.lambda_star, rng, mcmc["walkers"], mcmc["steps"], mcmc["burn"])[2])
        if log is not None and ((k + 1) % log_every == 0 or k + 1 == sets):
            log(f"calibration ({n} points): {k + 1}/{sets} training sets, {len(out['mcmc'])} with emcee, {time.perf_counter() - clock:.0f} s")
    for key in ("ml", "mcmc"):
        bounds = np.array(out[key]).reshape(-1, 2)
        hits = int(np.sum((bounds[:, 0] <= truth) & (truth <= bounds[:, 1])))
        out[f"{key}_bounds"] = bounds
        out[f"{key}_hits"] = hits
        out[f"{key}_interval"] = binomial_interval(hits, len(bounds)) if len(bounds) else (np.nan, np.nan)
    return out


@with_single_blas_thread
def prior_calibration(hyper: Mapping[str, Any], x_train, x_star: float, sets: int, rng: np.random.Generator):
    """Exact calibration check: truths drawn from the GP prior with known hyperparameters.

    Function values at the training inputs and the slope at x_star are drawn jointly from the
    prior (covariances (6)-(8)), noise v0 is added to the function values, and the slope is
    predicted with the same hyperparameters. The 95 % interval must then cover 95 % of truths.
    Returns (hits, sets).
    """
    x_train = np.asarray(x_train, float)
    v1, g, v0 = hyper["v1"], np.asarray(hyper["g"], float), hyper["v0"]
    xs = np.array([x_star])
    K = np.block(
        [
            [arcsine_kernel(x_train, x_train, v1, g), arcsine_kernel_grad_x(xs, x_train, v1, g).T],
            [arcsine_kernel_grad_x(xs, x_train, v1, g), arcsine_kernel_grad_xx(xs, xs, v1, g)],
        ]
    )
    L = np.linalg.cholesky(K + 1e-12 * np.eye(K.shape[0]))
    gp = ArcsineGP(hyperparameters={"v1": v1, "g": g, "v0": v0})
    hits = 0
    for _ in range(sets):
        joint = L @ rng.standard_normal(K.shape[0])
        y = joint[:-1] + np.sqrt(v0) * rng.standard_normal(x_train.size)
        gp.fit(x_train, y)
        m, s, (lo, hi) = slope_interval_ml(gp, x_star)
        hits += int(lo <= joint[-1] <= hi)
    return hits, sets


def posterior_curves(gp: ArcsineGP, grid, draws: int, rng: np.random.Generator):
    """Friction curves drawn from the GP posterior on ``grid``; shape (draws, len(grid))."""
    mean, cov = gp.predict_joint(grid)
    w, V = np.linalg.eigh(0.5 * (cov + cov.T))
    root = V * np.sqrt(np.clip(w, 0.0, None))
    return mean + rng.standard_normal((draws, len(grid))) @ root.T


def design_summary(car: QuarterCar, mean_slope: float, slope_std: float, v: float) -> dict:
    """Gains, schedule, damping band and the true curve's damping for one slope estimate."""
    K_p, T_i, _ = pid_gains(mean_slope, v, car)
    zeta_true, omega_0 = damping(friction_slope(car.lambda_star, car.mu_H, car.k), v, K_p, T_i, car)
    zeta_hi, _ = damping(mean_slope + 2 * slope_std, v, K_p, T_i, car)
    zeta_lo, _ = damping(mean_slope - 2 * slope_std, v, K_p, T_i, car)
    return {"K_p": float(K_p), "T_i": float(T_i), "omega_0": float(omega_0), "zeta_plus": float(zeta_hi), "zeta_minus": float(zeta_lo), "zeta_true": float(zeta_true)}

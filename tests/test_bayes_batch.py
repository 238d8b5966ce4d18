"""The batched log-posterior of the emcee cross-check: the batched LTI kernels equal the
one-system kernels, the batched PCE moments equal the one-by-one moments at random parameters in
the prior box (inadmissible ones flagged where ``moments`` raises), the batched log-posterior
equals the scalar one, and the samplers run in lockstep with batched evaluations give the chains
of the sequential scalar sampler for a fixed seed."""

import copy

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from uqdrive.inference.bayes import BoxPrior, MomentLikelihood, log_posterior, log_posterior_batch, log_posteriors, sample_ensembles
from uqdrive.numerics.batched_lti import block_diagonal, foh_discretise_batched, lti_response_batched
from uqdrive.numerics.integrate import foh_discretise_single, lti_response_single
from uqdrive.studies.bayes import UNCERTAIN, _model, coverage_study, posterior_case, prepare_data, summarise
from uqdrive.vehicle.chaos import LSTChaosModel
from uqdrive.vehicle.montecarlo import simulate_ensemble
from uqdrive.settings import Settings


def _close(got, want, rel=1e-12):
    """Equal to rounding: relative to the largest entry of ``want``."""
    scale = max(np.abs(want).max(), 1e-300)
    return np.abs(got - want).max() <= rel * scale


def _block_system(rng, B, b0, m, b, r):
    """B block-diagonal systems: one b0-block and m identical b-blocks (as the Galerkin LST:
    the parametric terms, then one block per linear germ), inputs reaching some blocks only."""
    N = b0 + m * b
    A = np.zeros((B, N, N))
    A[:, :b0, :b0] = rng.normal(size=(B, b0, b0)) - 2.0 * np.eye(b0)
    G = rng.normal(size=(B, b, b)) - 2.0 * np.eye(b)
    for j in range(m):
        A[:, b0 + j * b : b0 + (j + 1) * b, b0 + j * b : b0 + (j + 1) * b] = G
    E = np.zeros((B, N, r))
    E[:, :b0, : min(2, r)] = rng.normal(size=(B, b0, min(2, r)))
    for j in range(m):  # block j is reached by input column 2 + j (if there is one)
        if 2 + j < r:
            E[:, b0 + j * b : b0 + (j + 1) * b, 2 + j] = rng.normal(size=(B, b))
    return A, E


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**16), B=st.integers(1, 5), b0=st.integers(1, 6), m=st.integers(0, 4), b=st.integers(1, 4),
       K=st.integers(1, 60), every=st.integers(1, 7))
def test_batched_lti_equals_the_one_system_kernels(seed, B, b0, m, b, K, every):
    """Per member, the batched discretisation gives the one-system maps (same Van Loan blocks and
    exponentials) and the batched response the one-system response, also observed every s
    samples, to 1e-12 relative."""
    rng = np.random.default_rng(seed)
    r = 2 + m
    A, E = _block_system(rng, B, b0, m, b, r)
    g = rng.normal(size=(K + 1, r))
    x0 = rng.normal(size=A.shape[-1])
    blocks, P, Q = foh_discretise_batched(A, E, 0.1)
    Phi = block_diagonal(blocks, A.shape[-1])
    X = lti_response_batched(blocks, P, Q, g, x0, every=every)
    assert X.shape == (B, K // every + 1, A.shape[-1])
    for i in range(B):
        want = foh_discretise_single(A[i], E[i], 0.1)
        for got, w in zip((Phi[i], P[i], Q[i]), want):
            assert _close(got, w, 1e-13)
        assert _close(X[i], lti_response_single(*want, g, x0)[: K // every * every + 1 : every])


def test_identical_blocks_share_one_exponential_only_where_identical():
    """A group whose blocks differ in one member is split: the maps stay the one-system maps."""
    rng = np.random.default_rng(3)
    A, E = _block_system(rng, 3, 4, 3, 2, 5)
    A[1, 8:10, 8:10] += 0.5  # the last small block of member 1 differs
    blocks, P, Q = foh_discretise_batched(A, E, 0.1)
    Phi = block_diagonal(blocks, A.shape[-1])
    for i in range(3):
        for got, w in zip((Phi[i], P[i], Q[i]), foh_discretise_single(A[i], E[i], 0.1)):
            assert _close(got, w, 1e-13)


@pytest.fixture(scope="module")
def sampler_model(config):
    """The sampler's model of the default config (model_dt grid, KLE gusts)."""
    return _model(Settings.from_config(config), dt=config["bayes"]["model_dt"], gusts=True)


def _prior_draws(config, seed, n):
    """n parameter vectors uniform in the prior box (most put a quadrature node at mu <= 0 or l_f
    outside the wheelbase), then n in the part of the box where every node is physical."""
    prior = BoxPrior.from_settings(Settings.from_config(config))
    rng = np.random.default_rng(seed)
    box = prior.low + (prior.high - prior.low) * rng.random((n, prior.low.size))
    physical = box[rng.permutation(n)].copy()
    L = config["vehicle"]["wheelbase"]
    physical[:, 1] = rng.random(n) * physical[:, 0] / 2.5  # 4 Gauss-Hermite nodes reach +-2.33 std
    physical[:, 3] = rng.random(n) * np.minimum(physical[:, 2], L - physical[:, 2]).clip(0.0) / 2.5
    physical[:, 4:] = np.sort(physical[:, 4:], axis=1)
    return prior, np.concatenate([box, physical])


@settings(max_examples=6, deadline=None)
@given(seed=st.integers(0, 2**16))
@example(seed=2427)
def test_moments_batch_equals_moments_one_by_one(config, sampler_model, seed):
    """Random parameters in the prior box (admissible or not): the batch flags exactly those
    where ``moments`` raises, and its moments equal the one-by-one moments to 1e-11 of each
    state's largest value, on the full grid and observed every 3rd time.

    The two paths scale and square their exponentials differently (one per block against one of
    the whole Galerkin matrix), so they agree to rounding only: typically 1e-14, but 1.1e-12 for
    the variance at seed 2427 (a draw with mu = 0.11, std 0.028: low friction, slow lateral
    modes that carry the rounding of every step). 1e-11 keeps a 9x margin over that worst measured case."""
    _, thetas = _prior_draws(config, seed, 4)
    truth = Settings.from_config(config).uncertainty.theta(UNCERTAIN)
    thetas[:2] = truth * (1.0 + 0.1 * np.random.default_rng(seed).standard_normal((2, truth.size)))  # some surely admissible
    batch = sampler_model.moments_batch(thetas)
    every3 = sampler_model.moments_batch(thetas, every=3)
    assert np.array_equal(every3.time, sampler_model.time[::3])
    for i, theta in enumerate(thetas):
        try:
            one = sampler_model.moments(theta)
        except ValueError:
            assert not batch.admissible[i] and np.all(np.isnan(batch.mean[i]))
            continue
        assert batch.admissible[i]
        for got, got3, want in ((batch.mean[i], every3.mean[i], one.mean), (batch.variance[i], every3.variance[i], one.variance)):
            scale = np.abs(want).max(axis=1, keepdims=True)
            assert np.all(np.abs(got - want) <= 1e-11 * scale)
            assert np.all(np.abs(got3 - want[:, ::3]) <= 1e-11 * scale)


def _likelihood(model, truth, every, N=400, seed=0):
    """A likelihood of K model times (every ``every``-th) from synthetic Gaussian realisations."""
    r = model.moments(truth)
    idx = np.arange(every, model.time.size, every)
    rng = np.random.default_rng(seed)
    x = r.mean[:, None, idx] + r.std[:, None, idx] * rng.standard_normal((4, N, idx.size))
    return MomentLikelihood.from_samples(x, 0.01), idx


def test_log_posterior_batch_equals_the_scalar_log_posterior(config, sampler_model):
    """Inside and outside the prior, admissible or not: the batched log-posterior (model observed
    every 3rd time) is the scalar one per theta, -inf at the same places, else to 1e-9 relative."""
    truth = Settings.from_config(config).uncertainty.theta(UNCERTAIN)
    like, idx = _likelihood(sampler_model, truth, 3)
    prior, thetas = _prior_draws(config, 11, 10)
    near = truth * (1.0 + 0.02 * np.random.default_rng(4).standard_normal((6, truth.size)))
    thetas = np.concatenate([thetas, near, [truth * [1, 1, 1, 1, 1, -1]]])  # the last: low > high
    got = log_posterior_batch(thetas, sampler_model, like, prior, idx // 3, every=3)
    want = np.array([log_posterior(t, sampler_model, like, prior, idx) for t in thetas])
    assert np.array_equal(np.isfinite(got), np.isfinite(want)) and np.isfinite(want).sum() >= 6
    finite = np.isfinite(want)
    assert got[finite] == pytest.approx(want[finite], rel=1e-9)
    m = sampler_model.moments_batch(near)
    mean, variance = m.mean[..., idx], m.variance[..., idx]
    assert like.batch(mean, variance) == pytest.approx([like(a, b) for a, b in zip(mean, variance)], rel=1e-12)
    assert np.array_equal(prior.inside(thetas), [prior(t) == 0.0 for t in thetas])


def test_lockstep_sampler_gives_the_sequential_scalar_chain(config, sampler_model):
    """Two ensembles in lockstep, every half-ensemble update of both one batched model call,
    against the sequential sampler with one scalar log-posterior per walker (the code before
    batching): the same chains to the last bit and the same log-probabilities to rounding."""
    truth = Settings.from_config(config).uncertainty.theta(UNCERTAIN)
    like, idx = _likelihood(sampler_model, truth, 3)
    prior = BoxPrior.from_settings(Settings.from_config(config))
    starts = [truth, truth * 1.05]
    kw = {"walkers": 12, "max_steps": 30, "check_every": 30, "tau_factor": 50, "burn_in": 10, "moves": "de"}
    old = sample_ensembles(lambda t: log_posterior(t, sampler_model, like, prior, idx), starts, rng=np.random.default_rng(5), **kw)
    new = sample_ensembles(lambda calls: log_posteriors(sampler_model, [(t, like, prior, idx // 3) for _, t in calls], every=3),
                           starts, rng=np.random.default_rng(5), lockstep=True, **kw)
    for a, b in zip(old, new):
        assert np.array_equal(a["chain"], b["chain"])
        assert b["log_prob"] == pytest.approx(a["log_prob"], rel=1e-9)
        assert a["acceptance"] == b["acceptance"] and np.array_equal(a["tau"], b["tau"])


def _gaussian(t):
    return -0.5 * np.sum(((np.atleast_2d(t) - 1.0) / 0.1) ** 2, axis=-1)


def test_lockstep_equals_sequential_when_ensembles_stop_at_different_times():
    """Ensembles that converge after different numbers of checks leave the lockstep one by one;
    each chain is bit for bit the one of the sequential run (row-wise arithmetic); progress is
    logged at every check."""
    starts = [np.ones(2) * 1.05, np.ones(2) * 0.95, np.ones(2) * 1.3]
    kw = {"walkers": 8, "max_steps": 4000, "check_every": 100, "tau_factor": 30}
    seq = sample_ensembles(lambda t: float(_gaussian(t)[0]), starts, rng=np.random.default_rng(2), **kw)
    lines = []
    lock = sample_ensembles(lambda calls: [_gaussian(t) for _, t in calls], starts, rng=np.random.default_rng(2), lockstep=True,
                            log=lines.append, **kw)
    assert len({r["chain"].shape[0] for r in seq}) > 1  # the ensembles did stop at different times
    for a, b in zip(seq, lock):
        assert np.array_equal(a["chain"], b["chain"]) and np.array_equal(a["log_prob"], b["log_prob"])
        assert a["converged"] and b["converged"]
    assert len(lines) == sum(r["chain"].shape[0] // 100 for r in lock) and "converged" in lines[-1]


def test_lockstep_passes_an_error_to_every_sampler():
    """An evaluation that raises reaches the caller (no sampler is left waiting)."""
    def broken(calls):
        raise RuntimeError("model failed")

    with pytest.raises(RuntimeError, match="model failed"):
        sample_ensembles(broken, [np.ones(2), np.ones(2)], 8, np.random.default_rng(0), 100, check_every=50, lockstep=True)


@pytest.fixture(scope="module")
def small():
    from uqdrive.config import load_config

    from conftest import REPO

    cfg = load_config(REPO / "config" / "test.yaml")
    cfg["montecarlo"]["samples"] = 300
    cfg["bayes"]["check_every"] = 20
    cfg["bayes"]["burn_in"] = 10
    return cfg


def test_coverage_study_in_lockstep_equals_the_set_by_set_loop(small):
    """All calibration sets sampled together give each set's posterior of the one-set-at-a-time
    loop (same rng draws, same chains), hence the same coverage."""
    sets, steps = 2, 20
    hits, total, per_set = coverage_study(small, sets, steps, np.random.default_rng(9))
    rng = np.random.default_rng(9)
    want = []
    for k in range(sets):
        x, _ = prepare_data(small, simulate_ensemble(Settings.from_config(small), "lst", seed=int(small["seed"]) + 1000 + k))
        want.append(summarise(posterior_case(copy.deepcopy(small), x, None, rng, ensembles=1, max_steps=steps))["contains_truth"].astype(int))
    assert np.array_equal(per_set, np.array(want)) and total == 6 * sets and hits == int(np.sum(want))

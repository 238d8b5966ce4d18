import numpy as np
import pytest

from uqdrive.inference.bayes import BoxPrior, MomentLikelihood, gelman_rubin, sample_ensembles


def test_gelman_rubin_identical_chains_and_separated_chains():
    rng = np.random.default_rng(0)
    same = rng.standard_normal((4, 2000, 2))
    assert gelman_rubin(same) == pytest.approx([1.0, 1.0], abs=0.01)
    shifted = same + np.arange(4)[:, None, None] * 3.0
    assert np.all(gelman_rubin(shifted) > 2.0)


def test_whitened_likelihood_is_chi2_at_the_sampling_distribution():
    """Evaluated at the true moments, -2 log L of the sample statistics is chi-square with 8K
    degrees of freedom (here K = 3 times, 4 states): its mean over repetitions is ~24."""
    rng = np.random.default_rng(1)
    K, N = 3, 4000
    cov = np.array([[1.0, 0.8, 0.3], [0.8, 1.0, 0.8], [0.3, 0.8, 1.0]])
    L = np.linalg.cholesky(np.kron(np.eye(4), cov))
    values = []
    for _ in range(300):
        x = (L @ rng.standard_normal((4 * K, N))).reshape(4, K, N).transpose(0, 2, 1)
        like = MomentLikelihood.from_samples(x, model_error=0.0)
        values.append(-2.0 * like(np.zeros((4, K)), np.ones((4, K))))
    assert np.mean(values) == pytest.approx(8 * K, rel=0.1)


def test_whitened_likelihood_is_chi2_for_non_gaussian_states():
    """Uniform states (kurtosis 1.8): the std's sampling variance is (mu4 - s^4) / (4 s^2 N),
    not s^2 / (2N); with the fourth moments in the covariance -2 log L at the truth is still
    chi-square with 8K degrees of freedom on average (the Gaussian formula gives ~17 here)."""
    rng = np.random.default_rng(2)
    K, N = 3, 4000
    values = []
    for _ in range(300):
        x = rng.uniform(-np.sqrt(3.0), np.sqrt(3.0), (4, N, K))
        like = MomentLikelihood.from_samples(x, model_error=0.0)
        values.append(-2.0 * like(np.zeros((4, K)), np.ones((4, K))))
    assert np.mean(values) == pytest.approx(8 * K, rel=0.1)


def test_likelihood_corrects_the_estimated_precision():
    """With few realisations (N = 150, p = 24) the inverse of the estimated covariance overstates
    the precision by (N - 1) / (N - p - 2) = 1.20; with the Hartlap factor the mean of -2 log L
    at the truth is ~p (within 10 %; measured 25.1), without it it is ~30."""
    rng = np.random.default_rng(3)
    K, N = 3, 150
    values = []
    for _ in range(400):
        x = rng.standard_normal((4, N, K))
        like = MomentLikelihood.from_samples(x, model_error=0.0)
        values.append(-2.0 * like(np.zeros((4, K)), np.ones((4, K))))
    assert like.precision_factor == pytest.approx((N - 26) / (N - 1))
    assert np.mean(values) == pytest.approx(8 * K, rel=0.1)
    with pytest.raises(ValueError, match="cannot estimate the 24 x 24 covariance"):
        MomentLikelihood.from_samples(rng.standard_normal((4, 20, K)))


def test_box_prior():
    prior = BoxPrior(np.array([0.0] * 4 + [-10.0, -10.0]), np.array([2.0] * 4 + [10.0, 10.0]))
    assert prior([1, 1, 1, 1, -1, 1]) == 0.0
    assert prior([1, 1, 1, 1, 1, -1]) == -np.inf  # low >= high
    assert prior([3, 1, 1, 1, -1, 1]) == -np.inf


def test_sampler_recovers_a_gaussian_and_diagnoses():
    rng = np.random.default_rng(2)

    def log_prob(t):
        return -0.5 * np.sum(((t - 1.0) / 0.1) ** 2)

    runs = sample_ensembles(log_prob, [np.ones(2) * 1.05, np.ones(2) * 0.95], 8, rng, max_steps=4000, check_every=500, tau_factor=50)
    for r in runs:
        samples = r["chain"][r["burn"] :: r["thin"]].reshape(-1, 2)
        assert samples.mean(axis=0) == pytest.approx([1.0, 1.0], abs=0.02)
        assert samples.std(axis=0) == pytest.approx([0.1, 0.1], rel=0.15)
        assert r["converged"]


@pytest.mark.parametrize("moves", ["stretch", "de"])
def test_burn_in_is_discarded_and_moves_sample_correctly(moves):
    """After a burn-in from a tiny ball far in the tail, the stored chain starts in the bulk and
    both proposal schemes recover N(1, 0.1^2) (mean to 0.02, std to 15 %)."""
    rng = np.random.default_rng(5)

    def log_prob(t):
        return -0.5 * np.sum(((t - 1.0) / 0.1) ** 2)

    runs = sample_ensembles(log_prob, [np.ones(3) * 1.4], 8, rng, max_steps=3000, check_every=500, tau_factor=50, burn_in=500, moves=moves)
    r = runs[0]
    assert r["burn_in"] == 500 and r["chain"].shape[0] <= 3000
    assert np.all(np.abs(r["chain"][0].mean(axis=0) - 1.0) < 0.3)  # already in the bulk
    samples = r["chain"][r["burn"] :: r["thin"]].reshape(-1, 3)
    assert samples.mean(axis=0) == pytest.approx(np.ones(3), abs=0.02)
    assert samples.std(axis=0) == pytest.approx(np.full(3, 0.1), rel=0.15)


def test_unknown_moves_is_a_clear_error():
    with pytest.raises(ValueError, match="unknown emcee moves 'gibbs'"):
        sample_ensembles(lambda t: 0.0, [np.ones(2)], 8, np.random.default_rng(0), 100, moves="gibbs")

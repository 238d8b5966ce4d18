import numpy as np
import pytest

from uqdrive.vehicle.montecarlo import simulate_ensemble
from uqdrive.vehicle.noise import add_noise, added_noise_variance, noise_scale, noisy_ensemble
from uqdrive.vehicle.single_track import STATES
from uqdrive.settings import Settings


@pytest.fixture(scope="module")
def clean(config):
    return simulate_ensemble(Settings.from_config(config), "lst", samples=500)


def test_noise_scale_is_A_times_max_abs():
    s = np.array([[0.0, -2.0, 1.0], [0.5, 0.1, 0.2]])
    assert noise_scale(s, 0.1) == pytest.approx([0.2, 0.05])


@pytest.mark.parametrize("A", [0.01, 0.05, 0.1])
def test_added_variance_matches_5_6(clean, A):
    """The corruption s_c - s has variance A^2 E[|s|_max^2] at every time (5.6). Averaged over
    1000 independent time points of 500 samples the estimate's relative standard error is
    sqrt(2 / (n_t n)) (about 0.3 %, up to the spread of |s|_max), so 2 % is generous."""
    rng = np.random.default_rng(1)
    for name in STATES:
        s = clean[name].values
        noisy = add_noise(s, A, rng)
        measured = (noisy - s).var(axis=0, ddof=1)[1:].mean()
        assert measured == pytest.approx(added_noise_variance(s, A), rel=0.02)
        # The mean is unchanged within its standard error (thesis sec. 6.1).
        se = np.sqrt(added_noise_variance(s, A) / s.shape[0])
        assert np.abs(noisy.mean(axis=0) - s.mean(axis=0)).max() < 5 * se


def test_noise_adds_to_the_ensemble_variance(clean):
    """Var(noisy) - Var(clean) matches too, where the signal-noise cross term (zero in
    expectation, but with a spread of order 2 sqrt(var_s var_noise / n)) is small: the y state
    at A = 0.1, within 10 %."""
    s = clean["y"].values
    noisy = add_noise(s, 0.1, np.random.default_rng(2))
    gain = (noisy.var(axis=0, ddof=1) - s.var(axis=0, ddof=1))[1:].mean()
    assert gain == pytest.approx(added_noise_variance(s, 0.1), rel=0.1)


def test_noisy_ensemble_sets_attribute_and_refuses_double_noise(clean):
    noisy = noisy_ensemble(clean, 0.05, np.random.default_rng(0))
    assert noisy.attrs["noise_A"] == 0.05
    assert not np.array_equal(noisy["psi"].values, clean["psi"].values)
    with pytest.raises(ValueError, match="clean ensemble"):
        noisy_ensemble(noisy, 0.05, np.random.default_rng(0))

import numpy as np
import pytest

from uqdrive.vehicle.montecarlo import simulate_ensemble
from uqdrive.vehicle.statistics import ensemble_statistics, kl_divergence_series, noise_statistics, used_samples


@pytest.fixture(scope="module")
def nlst(config):
    ds = simulate_ensemble(config, "nlst", samples=40)
    ds["spun"][:3] = 1  # mark three realisations as spun to exercise the policy
    return ds


def test_exclude_policy_drops_spun_realisations(nlst):
    keep = ensemble_statistics(nlst, "keep")
    excl = ensemble_statistics(nlst, "exclude")
    assert keep.attrs["n_used"] == 40 and excl.attrs["n_used"] == 37
    expected = nlst["beta"].values[3:].mean(axis=0)
    assert excl["mean"].sel(state="beta").values == pytest.approx(expected)
    assert used_samples(nlst, "exclude").sum() == 37
    with pytest.raises(ValueError, match="spin policy"):
        used_samples(nlst, "drop")


def test_noise_statistics_zero_level_equals_clean(nlst):
    rngs = [np.random.default_rng(i) for i in range(2)]
    ns = noise_statistics(nlst, [0.0, 0.05], rngs, "exclude")
    clean = ensemble_statistics(nlst, "exclude")
    assert ns.sizes["noise"] == 2
    np.testing.assert_allclose(ns["std"].isel(noise=0), clean["std"])
    assert float(ns["std"].isel(noise=1).mean()) > float(clean["std"].mean())


def test_kl_series_is_zero_for_identical_and_nan_at_rest(nlst):
    s = ensemble_statistics(nlst, "keep")
    kl = kl_divergence_series(s, s)
    assert np.all(np.isnan(kl.isel(time=0)))
    assert np.nanmax(np.abs(kl.values)) < 1e-12

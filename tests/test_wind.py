import numpy as np
import pytest

from uqdrive.vehicle.montecarlo import wind_kle
from uqdrive.vehicle.uncertainty import squared_exponential_covariance
from uqdrive.studies.kle import direct_samples, kle_dataset
from uqdrive.settings import Settings


def test_direct_samples_have_the_covariance():
    """Sample covariance of 4000 paths matches (5.2): entries have SE <= sqrt(2/n) ~ 0.022."""
    t = np.linspace(0, 10, 41)
    x = direct_samples(t, 2.0, 4000, np.random.default_rng(3))
    assert np.cov(x.T) == pytest.approx(squared_exponential_covariance(t, t, 2.0), abs=0.12)


def test_kle_dataset_contents(config):
    kle = wind_kle(Settings.from_config(config))
    t = np.linspace(0, 10, 101)
    ds = kle_dataset(config, kle, t, 7, np.random.default_rng(0))
    assert ds.sizes["path"] == 7 and ds.sizes["kle_mode"] == 5
    assert ds.attrs["captured_variance"] == pytest.approx(0.953, abs=5e-4)
    assert "config_hash" in ds.attrs

import numpy as np
import pytest

from uqdrive.studies.bayes import posterior_case, prepare_data, summarise
from uqdrive.config import load_config
from uqdrive.vehicle.montecarlo import simulate_ensemble

from conftest import REPO
from uqdrive.settings import Settings


@pytest.fixture(scope="module")
def small():
    cfg = load_config(REPO / "config" / "test.yaml")
    cfg["montecarlo"]["samples"] = 300
    return cfg


def test_noisy_data_and_noise_estimate(small):
    ens = simulate_ensemble(Settings.from_config(small), "lst")
    x0, nv0 = prepare_data(small, ens)
    x1, nv1 = prepare_data(small, ens, 0.05)
    assert nv0 is None and nv1.shape == (4,) and np.all(nv1 > 0)
    assert x1.shape == x0.shape and not np.array_equal(x0, x1)


def test_posterior_case_runs_and_summarises(small):
    ens = simulate_ensemble(Settings.from_config(small), "lst")
    x, nv = prepare_data(small, ens)
    ds = posterior_case(small, x, nv, np.random.default_rng(0), ensembles=2, max_steps=100)
    assert ds["chain"].shape[0] == 2 and ds["chain"].shape[-1] == 6
    s = summarise(ds)
    assert np.all(s["low"] <= s["high"]) and s["samples"] > 0
    assert "optimiser_estimate" in ds.attrs and ds.sizes["parameter"] == 6
    assert ds.attrs["model_gusts"] == int(small["bayes"]["model_gusts"]) and "contains_estimate_unit_free" in s
    assert np.all(ds["burn_in"].values == small["bayes"]["burn_in"])


def test_likelihood_times_must_align(small):
    import copy

    cfg = copy.deepcopy(small)
    cfg["bayes"]["likelihood_dt"] = 0.25  # not a multiple of model_dt = 0.1
    ens = simulate_ensemble(Settings.from_config(cfg), "lst", samples=20)
    x, nv = prepare_data(cfg, ens)
    with pytest.raises(ValueError, match="likelihood_dt = 0.25 must be a multiple of"):
        posterior_case(cfg, x, nv, np.random.default_rng(0), ensembles=2, max_steps=20)

import numpy as np
import pytest

from uqdrive.vehicle.montecarlo import simulate_ensemble
from uqdrive.vehicle.statistics import ensemble_statistics, kl_divergence_series, noise_statistics, used_samples
from uqdrive.settings import Settings


@pytest.fixture(scope="module")
def nlst(config):
    ds = simulate_ensemble(Settings.from_config(config), "nlst", samples=40)
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


def _hand_made(n=6, T=5, spun=True, n_spun=None):
    """A tiny ensemble with known values: state s, realisation j, time k = 100 i_s + 10 j + k^2 / 2."""
    import xarray as xr

    from uqdrive.vehicle.single_track import STATES

    j, k = np.meshgrid(np.arange(n), np.arange(T), indexing="ij")
    data = {s: (("sample", "time"), 100.0 * i + 10.0 * j + 0.5 * k**2) for i, s in enumerate(STATES)}
    if spun:
        data["spun"] = (("sample",), np.array([0, 1] + [0] * (n - 2), np.int8))
    attrs = {"title": "raw", "model": "nlst", "steer": "normal", "seed": 3}
    if n_spun is not None:
        attrs["n_spun"] = n_spun
    return xr.Dataset(data, coords={"sample": np.arange(n), "time": 0.01 * np.arange(T)}, attrs=attrs)


def test_statistics_of_a_hand_made_ensemble():
    """Mean and ddof=1 standard deviation over the used realisations (numpy directly, rel 1e-14);
    the source's attributes are kept (title replaced), counts recorded."""
    ds = _hand_made(n_spun=1)
    for policy, used in (("keep", np.arange(6)), ("exclude", np.array([0, 2, 3, 4, 5]))):
        st = ensemble_statistics(ds, policy)
        x = ds["beta"].values[used]
        assert st["mean"].sel(state="beta").values == pytest.approx(x.mean(axis=0), rel=1e-14)
        assert st["std"].sel(state="beta").values == pytest.approx(x.std(axis=0, ddof=1), rel=1e-14)
        assert st["mean"].dims == ("state", "time") and list(st["state"].values) == ["psi", "psi_dot", "beta", "y"]
        assert (st.attrs["n_samples"], st.attrs["n_used"], st.attrs["n_spun_total"], st.attrs["spin_policy"]) == (6, used.size, 1, policy)
        assert (st.attrs["model"], st.attrs["steer"], st.attrs["seed"]) == ("nlst", "normal", 3)
        assert st.attrs["title"] == "ensemble statistics (nlst, normal)"
        assert "y: m" in st.attrs["state_units"]


def test_exclude_without_a_spin_record_uses_everything():
    ds = _hand_made(spun=False)
    assert used_samples(ds, "exclude").tolist() == [True] * 6
    st = ensemble_statistics(ds, "exclude")
    assert st.attrs["n_used"] == 6 and st.attrs["n_spun_total"] == 0


def test_noise_statistics_against_the_noise_module():
    """Per level: statistics of add_noise(signal, A, rng) over the used realisations (the same
    draws: the level's generator serves the states in order; rel 1e-12), the noise variance estimated per state from those data, and the variance
    (5.6) adds, A^2 E[max|s|^2], from the noise module."""
    from uqdrive.vehicle.noise import add_noise, added_noise_variance, estimate_noise_variance

    ds = _hand_made(n=8, T=30)
    ns = noise_statistics(ds, [0.0, 0.1], [np.random.default_rng(5), np.random.default_rng(6)], "exclude")
    mask = used_samples(ds, "exclude")
    rng = np.random.default_rng(6)
    noisy = [add_noise(ds[s].values, 0.1, rng)[mask] for s in ("psi", "psi_dot", "beta", "y")][-1]  # states in order, one generator
    assert ns.sizes["noise"] == 2 and ns["noise"].values.tolist() == [0.0, 0.1]
    y = ns.sel(noise=0.1, state="y")
    assert y["mean"].values == pytest.approx(noisy.mean(axis=0), rel=1e-12)
    assert y["std"].values == pytest.approx(noisy.std(axis=0, ddof=1), rel=1e-12)
    assert float(ns["noise_variance"].sel(noise=0.1, state="y")) == pytest.approx(estimate_noise_variance(noisy), rel=1e-12)
    assert float(ns["noise_variance_true"].sel(noise=0.1, state="y")) == pytest.approx(added_noise_variance(ds["y"].values, 0.1, mask), rel=1e-12)
    clean = ensemble_statistics(ds, "exclude")
    np.testing.assert_allclose(ns["mean"].isel(noise=0), clean["mean"], rtol=1e-14)
    assert ns.attrs["title"] == "noise-corrupted ensemble statistics (nlst)"


def test_kl_series_against_the_closed_form():
    """D_KL(N(m1, s1^2) || N(m2, s2^2)) = ln(s2/s1) + (s1^2 + (m1 - m2)^2) / (2 s2^2) - 1/2 at
    every (state, time) (rel 1e-12), in nats, with the statistics' coordinates."""
    ds = _hand_made(n=6, T=5)
    p, q = ensemble_statistics(ds, "keep"), ensemble_statistics(ds, "exclude")
    kl = kl_divergence_series(p, q)
    m1, s1, m2, s2 = p["mean"].values, p["std"].values, q["mean"].values, q["std"].values
    assert kl.values == pytest.approx(np.log(s2 / s1) + (s1**2 + (m1 - m2) ** 2) / (2 * s2**2) - 0.5, rel=1e-12)
    assert kl.dims == ("state", "time") and kl.attrs["units"] == "nat" and kl.name == "kl_divergence"

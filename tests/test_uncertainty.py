import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from uqdrive.vehicle.uncertainty import (Germs, ParameterDistribution, germ_from_uniform, kle_nystrom, squared_exponential_covariance,
                                         uniform_from_germ)


@pytest.fixture(scope="module")
def kle():
    return kle_nystrom(0.0, 10.0, 2.0, 350, 0.95)


def test_kle_keeps_five_eigenpairs_with_facts_eigenvalues(kle):
    # FACTS: 3.296, 2.653, 1.853, 1.127, 0.602 (printed to 3 decimals), sum / T = 0.953.
    assert kle.n_modes == 5
    assert kle.eigenvalues == pytest.approx([3.296, 2.653, 1.853, 1.127, 0.602], abs=6e-4)
    assert kle.captured_variance == pytest.approx(0.953, abs=5e-4)
    assert kle.all_eigenvalues.sum() == pytest.approx(10.0, rel=1e-10)  # trace = T for unit variance


def test_eigenfunctions_orthonormal_under_quadrature(kle):
    f = kle.nodal_functions
    gram = (f * kle.weights) @ f.T
    assert gram == pytest.approx(np.eye(kle.n_modes), abs=1e-10)


def test_nystrom_interpolation_reproduces_nodes(kle):
    assert kle.eigenfunctions(kle.nodes) == pytest.approx(kle.nodal_functions, rel=1e-8, abs=1e-10)


def test_truncated_kle_covariance_approximates_5_2(kle):
    t = np.linspace(0, 10, 201)
    f = kle.eigenfunctions(t)
    C_kle = (f.T * kle.eigenvalues) @ f
    C = squared_exponential_covariance(t, t, 2.0)
    # Mean pointwise error bounded by the dropped variance share (about 4.7 %).
    assert np.mean(np.abs(np.diag(C_kle) - 1.0)) < 1 - kle.captured_variance + 0.01
    full = kle_nystrom(0.0, 10.0, 2.0, 350, 1.0 - 1e-12)
    g = full.eigenfunctions(t)
    assert (g.T * full.eigenvalues) @ g == pytest.approx(C, abs=1e-6)


def test_uniform_germ_map_5_11():
    assert uniform_from_germ(np.array([-1.0, 0.0, 1.0]), -400.0, 400.0) == pytest.approx([-400.0, 0.0, 400.0])
    xi = np.array([-1.0, -0.3, 0.0, 0.7, 1.0])
    assert germ_from_uniform(uniform_from_germ(xi, -250.0, 600.0), -250.0, 600.0) == pytest.approx(xi, abs=1e-15)


def test_both_ensembles_draw_the_mean_winds_germ_alike():
    """The Monte Carlo ensembles' germs (ParameterDistribution) and the augmented model's (Germs)
    hold the same U(-1, 1) germ of the mean wind: after 3 n normals from the same stream, the
    same n numbers, spanning [-1, 1] (5000 draws reach within 0.01 of each end: P(miss) = 0.995^5000)."""
    n = 5000
    mc = ParameterDistribution.sample_germs(np.random.default_rng(3), n)[:, 3]
    aug = Germs.draw(np.random.default_rng(3), n, 2).wind
    assert np.array_equal(mc, aug)
    assert -1.0 <= aug.min() < -0.99 and 0.99 < aug.max() <= 1.0


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_germ_maps_reproduce_moments(seed):
    """Sample moments of (5.8)-(5.11) match the distributions within 5 standard errors."""
    dist = ParameterDistribution()
    n = 20000
    draws = dist.from_germs(dist.sample_germs(np.random.default_rng(seed), n))
    for name in ("mu", "m_load", "l_f"):
        mean, std = getattr(dist, name)
        assert abs(draws[name].mean() - mean) < 5 * std / np.sqrt(n)
        assert abs(draws[name].std() - std) < 5 * std / np.sqrt(2 * n)
    low, high = dist.F_w_mean
    assert draws["F_w_mean"].min() >= low and draws["F_w_mean"].max() <= high
    # SE of a sample std: sigma sqrt((kurtosis - 1) / (4 n)), kurtosis 9/5 for a uniform.
    sigma = (high - low) / np.sqrt(12)
    assert abs(draws["F_w_mean"].std() - sigma) < 5 * sigma * np.sqrt(0.8 / (4 * n))

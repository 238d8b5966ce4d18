"""The check of the posterior's surrogate (uqdrive.inference.surrogate.first_order_shift):
golden values from Gaussian tilts, invariances, and the case that made it the criterion: a
heavy-tailed error that moves no summary passes, a small tilt that does move one fails."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from uqdrive.inference.surrogate import first_order_shift


def _gaussian(S=20_000, p=3, seed=0):
    return np.random.default_rng(seed).standard_normal((S, p))


@pytest.mark.parametrize("g", [-0.6, 0.3, 1.0])
def test_a_linear_tilt_moves_the_mean_by_its_slope(g):
    """q = N(0, 1) tilted by exp(g z) is N(g, 1): the mean moves by g posterior sd exactly, the
    sd not at all. Tolerance: 4 of the estimate's own standard errors (20 000 draws)."""
    x = _gaussian()
    mean_shift, sd_shift, mean_se, sd_se = first_order_shift(x, g * x[:, 1] + 7.0)
    assert abs(mean_shift[1] - g) <= 4 * mean_se[1], (mean_shift, mean_se)
    assert np.all(np.abs(mean_shift[[0, 2]]) <= 4 * mean_se[[0, 2]])
    assert np.all(np.abs(sd_shift) <= 4 * sd_se)


@pytest.mark.parametrize("c", [-0.1, 0.05, 0.1])
def test_a_quadratic_tilt_moves_the_sd(c):
    """q = N(0, 1) tilted by exp(c z^2) has sd 1 / sqrt(1 - 2 c) = 1 + c + O(c^2): the first-order
    sd shift is c (Cov(z^2, c z^2) / 2 = c Var(z^2) / 2, Var(z^2) = 2), the mean's 0."""
    x = _gaussian()
    mean_shift, sd_shift, mean_se, sd_se = first_order_shift(x, c * x[:, 0] ** 2)
    assert abs(sd_shift[0] - c) <= 4 * sd_se[0], (sd_shift, sd_se)
    assert np.all(np.abs(mean_shift) <= 4 * mean_se)
    assert abs((1 / np.sqrt(1 - 2 * c) - 1) - c) <= 2 * c**2  # the first order is the exact ratio's


@settings(max_examples=40, deadline=None)
@given(offset=st.floats(-1e3, 1e3), scale=st.floats(1e-3, 1e3), shift=st.floats(-1e3, 1e3), seed=st.integers(0, 2**16))
def test_shifts_are_invariant_to_a_constant_error_and_to_the_units(offset, scale, shift, seed):
    """A constant added to the error does not move a posterior; the shifts are in posterior sd, so
    they do not depend on the parameters' units or origin; a sign flip of a parameter flips its
    mean shift only."""
    rng = np.random.default_rng(seed)
    x = rng.standard_normal((50, 2))
    error = rng.standard_normal(50) + 0.5 * x[:, 0]
    ref = first_order_shift(x, error)
    moved = first_order_shift(scale * x + shift, error + offset)
    for a, b in zip(ref, moved):
        np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-9)
    flipped = first_order_shift(x * np.array([-1.0, 1.0]), error)
    np.testing.assert_allclose(flipped[0], ref[0] * np.array([-1.0, 1.0]), atol=1e-12)
    np.testing.assert_allclose(flipped[1], ref[1], atol=1e-12)


def test_a_heavy_tailed_error_passes_and_a_tilt_fails():
    """64 draws as the posterior takes them. An error with no relation to the parameters but a
    heavy tail (t with 3 degrees of freedom, scale 0.6: its standard deviation over the draws is
    above 0.5, the former criterion's limit) moves no summary beyond 0.5 sd; a tilt of 0.8 sd
    along one parameter, with a small error spread, does and is caught."""
    rng = np.random.default_rng(3)
    x = rng.standard_normal((64, 7))
    tail = 0.6 * rng.standard_t(3, 64)
    assert np.std(tail, ddof=1) > 0.5
    m, s, _, _ = first_order_shift(x, tail)
    assert max(np.max(np.abs(m)), np.max(np.abs(s))) <= 0.5
    m, s, _, _ = first_order_shift(x, 0.8 * x[:, 2] + 0.05 * rng.standard_normal(64))
    assert np.argmax(np.abs(m)) == 2 and np.max(np.abs(m)) > 0.5


def test_too_few_or_mismatched_draws_are_refused():
    with pytest.raises(ValueError, match="at least 3"):
        first_order_shift(np.zeros((2, 1)), np.zeros(2))
    with pytest.raises(ValueError, match="matching"):
        first_order_shift(np.zeros((5, 1)), np.zeros(4))

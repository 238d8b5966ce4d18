import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from uqdrive.numerics.pce import PolynomialChaos


def test_projection_recovers_a_polynomial():
    pc = PolynomialChaos(["normal", "uniform"], 3, quadrature_points=4)
    rng = np.random.default_rng(0)
    coeffs = rng.normal(size=pc.n_terms)
    values = pc.evaluate(coeffs, pc.nodes)
    assert pc.project(values) == pytest.approx(coeffs, abs=1e-12)


def test_sobol_of_additive_function():
    """f = a xi1 + b xi2^2 (both normal): xi2^2 = sqrt(2) He2~ + 1, so Var = a^2 + 2 b^2 and the
    first-order indices equal the totals: a^2 / Var and 2 b^2 / Var."""
    a, b = 2.0, 1.5
    pc = PolynomialChaos(["normal", "normal"], 2, quadrature_points=3)
    c = pc.project(a * pc.nodes[:, 0] + b * pc.nodes[:, 1] ** 2)
    var = a**2 + 2 * b**2
    assert pc.mean(c) == pytest.approx(b) and pc.variance(c) == pytest.approx(var)
    first, total = pc.sobol(c), pc.sobol(c, total=True)
    assert first == pytest.approx([a**2 / var, 2 * b**2 / var])
    assert total == pytest.approx(first)


def test_sobol_of_pure_interaction_and_groups():
    pc = PolynomialChaos(["normal", "uniform", "normal"], 2, quadrature_points=3)
    c = pc.project(pc.nodes[:, 0] * pc.nodes[:, 1])
    assert pc.sobol(c) == pytest.approx([0.0, 0.0, 0.0], abs=1e-14)
    assert pc.sobol(c, total=True) == pytest.approx([1.0, 1.0, 0.0])
    assert pc.sobol(c, groups=[[0, 1], [2]]) == pytest.approx([1.0, 0.0])


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 10_000))
def test_moments_against_monte_carlo(seed):
    """Mean and variance of a random order-2 expansion agree with 200 000 samples within 5 SE."""
    rng = np.random.default_rng(seed)
    pc = PolynomialChaos(["normal", "uniform"], 2)
    c = rng.normal(size=pc.n_terms)
    xi = np.column_stack([rng.standard_normal(200_000), rng.uniform(-1, 1, 200_000)])
    f = pc.evaluate(c, xi)
    se = f.std() / np.sqrt(f.size)
    assert abs(f.mean() - pc.mean(c)) < 5 * se
    assert abs(f.var() - pc.variance(c)) < 5 * np.sqrt(np.mean((f - f.mean()) ** 4) / f.size)

import numpy as np
import pytest
from scipy.integrate import quad

from uqdrive.numerics.metrics import kl_divergence_normal, wasserstein2_normal, wasserstein2_uniform


def test_kl_divergence_of_identical_normals_is_zero():
    assert kl_divergence_normal(1.0, 2.0, 1.0, 2.0) == pytest.approx(0.0)


def test_kl_divergence_closed_form():
    # ln(2/1) + (1 + 1) / 8 - 1/2
    assert kl_divergence_normal(0.0, 1.0, 1.0, 2.0) == pytest.approx(np.log(2) + 0.25 - 0.5)


def test_kl_divergence_undefined_for_degenerate():
    assert np.isnan(kl_divergence_normal(0.0, 0.0, 0.0, 1.0))


def test_wasserstein_uniform_facts_value():
    # FACTS: W2(U(0,1), U(-1,2)) = 0.577 with the corrected formula (the thesis prints 1.15).
    assert wasserstein2_uniform(0.0, 1.0, -1.0, 2.0) == pytest.approx(1 / np.sqrt(3), rel=1e-12)


@pytest.mark.parametrize("a1,b1,a2,b2", [(0, 1, -1, 2), (-400, 400, -425, 420), (2, 3, 5, 9)])
def test_wasserstein_uniform_equals_quantile_integral(a1, b1, a2, b2):
    integral, _ = quad(lambda p: ((a1 + p * (b1 - a1)) - (a2 + p * (b2 - a2))) ** 2, 0, 1)
    assert wasserstein2_uniform(a1, b1, a2, b2) == pytest.approx(np.sqrt(integral), rel=1e-10)


def test_wasserstein_normal():
    assert wasserstein2_normal(1.0, 0.2, 0.995, 0.205) == pytest.approx(np.hypot(0.005, 0.005))


def test_thesis_printed_uniform_formula_gives_its_quoted_values():
    from uqdrive.numerics.metrics import wasserstein2_uniform_thesis

    assert wasserstein2_uniform_thesis(0.0, 1.0, -1.0, 2.0) == pytest.approx(1.15, abs=0.005)
    assert wasserstein2_uniform_thesis(0.0, 10.0, -10.0, 20.0) == pytest.approx(11.5, abs=0.05)


def test_normalised_distances_5_32_5_33():
    from uqdrive.numerics.metrics import normalised_w2_normal, normalised_w2_uniform

    assert normalised_w2_normal(1.0, 0.2, 1.0, 0.2) == pytest.approx(0.0)
    assert normalised_w2_normal(1.2, 0.2, 1.0, 0.2) == pytest.approx(1.0)
    assert normalised_w2_normal(1.0, -0.2, 1.0, 0.2) == pytest.approx(0.0)  # |sigma| (cost is even in it)
    assert normalised_w2_uniform(-400, 400, -400, 400) == pytest.approx(0.0)
    # Shift by half the span: U(0, 2) against U(-1, 1) has W2 = 1.
    assert normalised_w2_uniform(0, 800, -400, 400) == pytest.approx(1.0)

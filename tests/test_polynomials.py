from math import comb

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from uqdrive.numerics.polynomials import family, multi_indices, n_terms, tensor_quadrature


@pytest.mark.parametrize("name", ["normal", "uniform"])
@pytest.mark.parametrize("degree", [0, 1, 4, 8])
def test_orthonormal_by_quadrature(name, degree):
    fam = family(name)
    x, w = fam.quadrature(degree + 1)  # exact for degree 2 * degree + 1 >= 2 * degree
    V = fam.evaluate(x, degree)
    assert (V.T * w) @ V == pytest.approx(np.eye(degree + 1), abs=1e-12)


def test_low_degree_polynomials_closed_form():
    x = np.array([-0.7, 0.3, 2.0])
    He = family("normal").evaluate(x, 3)
    assert He[:, 2] == pytest.approx((x**2 - 1) / np.sqrt(2))
    assert He[:, 3] == pytest.approx((x**3 - 3 * x) / np.sqrt(6))
    L = family("uniform").evaluate(x, 2)
    assert L[:, 2] == pytest.approx(np.sqrt(5) * 0.5 * (3 * x**2 - 1))


def test_quadrature_moments():
    x, w = family("normal").quadrature(5)
    assert w.sum() == pytest.approx(1.0) and w @ x**4 == pytest.approx(3.0)
    x, w = family("uniform").quadrature(3)
    assert w @ x**2 == pytest.approx(1 / 3)


@settings(max_examples=30, deadline=None)
@given(n_germs=st.integers(1, 6), order=st.integers(0, 5))
def test_multi_index_count_and_degree(n_germs, order):
    idx = multi_indices(n_germs, order)
    assert idx.shape == (comb(n_germs + order, order), n_germs) == (n_terms(n_germs, order), n_germs)
    assert len({tuple(r) for r in idx}) == idx.shape[0]
    assert np.all(np.diff(idx.sum(axis=1)) >= 0)  # graded
    assert idx.sum(axis=1).max() == order


def test_table_4_4_order():
    assert multi_indices(2, 3).tolist() == [[0, 0], [1, 0], [0, 1], [2, 0], [1, 1], [0, 2], [3, 0], [2, 1], [1, 2], [0, 3]]


def test_tensor_quadrature_integrates_products():
    nodes, w = tensor_quadrature([family("normal"), family("uniform")], [3, 2])
    assert nodes.shape == (6, 2) and w.sum() == pytest.approx(1.0)
    assert w @ (nodes[:, 0] ** 2 * nodes[:, 1] ** 2) == pytest.approx(1 / 3)


def test_bad_input_is_named():
    with pytest.raises(ValueError, match="unsupported germ distribution 'gamma'"):
        family("gamma")
    with pytest.raises(ValueError, match="order must be non-negative"):
        multi_indices(2, -1)
    with pytest.raises(ValueError, match="degree must be non-negative"):
        family("normal").evaluate(0.0, -2)
    with pytest.raises(ValueError, match="at least one point"):
        family("uniform").quadrature(0)

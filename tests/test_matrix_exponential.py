"""Batched matrix exponentials and Frechet derivatives against SciPy."""

import numpy as np
import pytest
from scipy.linalg import expm, expm_frechet

from uqdrive.numerics.matrix_exponential import batched_expm, expm_frechet_directions


def test_batched_expm_equals_scipy_for_every_matrix_of_the_stack():
    rng = np.random.default_rng(9)
    M = rng.normal(size=(5, 6, 6)) * np.array([0.01, 0.3, 1.0, 3.0, 10.0])[:, None, None]
    got = batched_expm(M)
    for g, m in zip(got, M):
        want = expm(m)
        assert g == pytest.approx(want, rel=1e-12, abs=1e-12 * np.abs(want).max())


def test_frechet_directions_equal_scipy():
    """All directions in one batched Taylor pass equal scipy's expm_frechet per direction to
    1e-12 relative, for a Van Loan-sized matrix whose norm needs several squarings."""
    rng = np.random.default_rng(6)
    M = rng.normal(size=(12, 12))
    M *= 6.0 / np.abs(M).sum(axis=0).max()
    D = rng.normal(size=(3, 12, 12))
    got = expm_frechet_directions(M, D)
    for g, d in zip(got, D):
        want = expm_frechet(M, d, compute_expm=False)
        assert g == pytest.approx(want, rel=1e-12, abs=1e-12 * np.abs(want).max())

"""Adjoint derivatives of the exactly discretised response against finite differences."""

import numpy as np
import pytest

from uqdrive.numerics.adjoint import backward_recursion, foh_response_vjp
from uqdrive.numerics.integrate import foh_discretise_single, lti_response_single


def test_backward_recursion_is_the_transpose_of_the_forward_map():
    """<G, X(d)> = <lambda_{1:}, d> for x_{k+1} = Phi x_k + d_k, x_0 = 0 (to 1e-12)."""
    rng = np.random.default_rng(0)
    Phi = 0.5 * rng.normal(size=(3, 3))
    d = rng.normal(size=(20, 3))
    X = np.zeros((21, 3))
    for k in range(20):
        X[k + 1] = Phi @ X[k] + d[k]
    G = rng.normal(size=(21, 3))
    lam = backward_recursion(Phi, G)
    assert np.sum(G * X) == pytest.approx(np.sum(lam[1:] * d), rel=1e-12)


def test_foh_response_vjp_matches_central_differences():
    """dJ/dA and dJ/dE of J = <G, X> for a stable 4-state system with 2 ramp/sine inputs, against
    central differences (h = 1e-6: truncation ~1e-12, round-off ~1e-9 relative)."""
    rng = np.random.default_rng(1)
    A = rng.normal(size=(4, 4)) - 3.0 * np.eye(4)
    E = rng.normal(size=(4, 2))
    t = np.linspace(0.0, 2.0, 41)
    g = np.column_stack([np.sin(3 * t), t])
    G = rng.normal(size=(41, 4))
    h = t[1]

    def J(A, E):
        return np.sum(G * lti_response_single(*foh_discretise_single(A, E, h), g, np.zeros(4)))

    Phi = foh_discretise_single(A, E, h)[0]
    X = lti_response_single(*foh_discretise_single(A, E, h), g, np.zeros(4))
    dA, dE = foh_response_vjp(A, E, h, Phi, g, X, G)
    eps = 1e-6
    for (i, j) in [(0, 0), (1, 3), (3, 2)]:
        D = np.zeros_like(A)
        D[i, j] = eps
        assert dA[i, j] == pytest.approx((J(A + D, E) - J(A - D, E)) / (2 * eps), rel=1e-6)
    for (i, j) in [(0, 0), (2, 1)]:
        D = np.zeros_like(E)
        D[i, j] = eps
        assert dE[i, j] == pytest.approx((J(A, E + D) - J(A, E - D)) / (2 * eps), rel=1e-6)

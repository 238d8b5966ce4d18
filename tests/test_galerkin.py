"""Galerkin PCE of scalar systems against closed forms."""

import numpy as np
import pytest

from uqdrive.numerics.galerkin import GalerkinProjector
from uqdrive.numerics.integrate import foh_discretise_single, lti_response_single


def _scalar_decay(dist, a0, s, order, t_end=1.0, steps=100):
    pr = GalerkinProjector([dist], 0, order, quadrature_points=order + 2)
    xi = pr.nodes[:, 0]
    A = pr.matrix((-(a0 + s * xi))[:, None, None])
    E = pr.input_matrix(np.zeros((xi.size, 1, 1)))
    x0 = pr.initial_state(np.ones((xi.size, 1)))
    maps = foh_discretise_single(A, E, t_end / steps)
    X = lti_response_single(*maps, np.zeros((steps + 1, 1)), x0)
    c = pr.coefficients(X)[:, 0, :]
    t = np.linspace(0, t_end, steps + 1)
    return t, c[:, 0], np.sum(c[:, 1:] ** 2, axis=1)


def test_gaussian_rate_closed_form():
    """x' = -(a0 + s xi) x, xi ~ N(0,1): E x = exp(-a0 t + s^2 t^2 / 2),
    E x^2 = exp(-2 a0 t + 2 s^2 t^2). Order 8 is exact to 1e-9 on [0, 1]."""
    a0, s = 1.0, 0.3
    t, mean, var = _scalar_decay("normal", a0, s, 8)
    assert mean == pytest.approx(np.exp(-a0 * t + s**2 * t**2 / 2), abs=1e-9)
    exact_var = np.exp(-2 * a0 * t + 2 * s**2 * t**2) - np.exp(-2 * a0 * t + s**2 * t**2)
    assert var == pytest.approx(exact_var, abs=1e-9)


def test_uniform_rate_closed_form():
    """xi ~ U(-1,1): E x = e^{-a0 t} sinh(s t) / (s t), E x^2 = e^{-2 a0 t} sinh(2 s t) / (2 s t)."""
    a0, s = 1.0, 0.5
    t, mean, var = _scalar_decay("uniform", a0, s, 6)
    st = np.where(t > 0, s * t, 1.0)
    m = np.exp(-a0 * t) * np.where(t > 0, np.sinh(st) / st, 1.0)
    m2 = np.exp(-2 * a0 * t) * np.where(t > 0, np.sinh(2 * st) / (2 * st), 1.0)
    assert mean == pytest.approx(m, abs=1e-10)
    assert var == pytest.approx(m2 - m**2, abs=1e-10)


def test_linear_germ_input():
    """x' = -x + sigma xi h(t) with xi ~ N(0, 1), h = 1: mean 0, std sigma (1 - e^{-t})."""
    pr = GalerkinProjector(["normal"], 1, 1, quadrature_points=2)
    Q = pr.nodes.shape[0]
    A = pr.matrix(-np.ones((Q, 1, 1)))
    E = np.concatenate([pr.input_matrix(np.zeros((Q, 1, 1))), pr.linear_input_matrix(np.full((Q, 1, 1), 2.0))], axis=1)
    maps = foh_discretise_single(A, E, 0.01)
    g = np.column_stack([np.zeros(201), np.ones(201)])
    c = pr.coefficients(lti_response_single(*maps, g, np.zeros(A.shape[0])))[:, 0, :]
    t = np.arange(201) * 0.01
    assert c[:, 0] == pytest.approx(0.0, abs=1e-15)
    assert np.sqrt((c[:, 1:] ** 2).sum(axis=1)) == pytest.approx(2.0 * (1 - np.exp(-t)), rel=1e-12, abs=1e-14)


def test_factorised_tensor_matches_dense_definition():
    pr = GalerkinProjector(["normal", "uniform"], 2, 2, quadrature_points=3)
    rng = np.random.default_rng(1)
    Q, P = pr.nodes.shape[0], pr.n_terms
    v = rng.normal(size=(Q, 2, 2))
    psi_par = pr.chaos.indices  # only to count terms
    G = pr.G_par[pr.par][:, pr.par] * pr.same_linear[:, :, None]
    dense = np.einsum("klq,qij->ikjl", G, v).reshape(2 * P, 2 * P)
    assert pr.matrix(v) == pytest.approx(dense)
    assert psi_par.shape == (P, 4)


def test_bad_projector_input():
    with pytest.raises(ValueError, match="quadrature_points"):
        GalerkinProjector(["normal"], 0, 2, quadrature_points=0)
    with pytest.raises(ValueError, match="unsupported germ distribution"):
        GalerkinProjector(["lognormal"], 0, 2)
    with pytest.raises(ValueError, match="order must be non-negative"):
        GalerkinProjector(["normal"], 0, -1)


def test_uniform_linear_germ_initial_state():
    """x' = -x, x(0) = a + b xi with xi ~ U(-1, 1): mean a e^{-t}, std |b| e^{-t} / sqrt(3)."""
    pr = GalerkinProjector(["normal"], ["uniform"], 1, quadrature_points=2)
    Q = pr.nodes.shape[0]
    A = pr.matrix(-np.ones((Q, 1, 1)))
    x0 = pr.initial_state(np.full((Q, 1), 2.0)) + pr.linear_initial_state(np.full((Q, 1, 1), 3.0))
    maps = foh_discretise_single(A, pr.input_matrix(np.zeros((Q, 1, 1))), 0.01)
    c = pr.coefficients(lti_response_single(*maps, np.zeros((101, 1)), x0))[:, 0, :]
    t = np.arange(101) * 0.01
    assert c[:, 0] == pytest.approx(2.0 * np.exp(-t), rel=1e-12)
    assert np.sqrt((c[:, 1:] ** 2).sum(axis=1)) == pytest.approx(3.0 / np.sqrt(3.0) * np.exp(-t), rel=1e-12)


def test_state_selection_equals_rows_and_columns_of_the_full_matrices():
    """``states`` gathers exactly the rows (and columns) of the full d P layout, in the given
    order, also with leading derivative axes."""
    pr = GalerkinProjector(["normal", "uniform"], 2, 2, quadrature_points=3)
    rng = np.random.default_rng(7)
    Q, d = pr.nodes.shape[0], 3
    states = rng.permutation(d * pr.n_terms)[:11]
    A, E, F = rng.normal(size=(2, Q, d, d)), rng.normal(size=(2, Q, d, 2)), rng.normal(size=(2, Q, d, 2))
    assert pr.matrix(A, states) == pytest.approx(pr.matrix(A)[:, states][:, :, states], rel=1e-14, abs=1e-14)
    assert pr.input_matrix(E, states) == pytest.approx(pr.input_matrix(E)[:, states], rel=1e-14, abs=1e-14)
    assert pr.linear_input_matrix(F, states) == pytest.approx(pr.linear_input_matrix(F)[:, states], rel=1e-14, abs=1e-14)


def test_block_order_makes_consecutive_decoupled_blocks():
    """The excited states in block order: the parametric-only block, then one block per linear
    germ (identical matrices), each consecutive, and A_PCE block diagonal in that order."""
    from uqdrive.numerics.recursion import identical_block_groups

    pr = GalerkinProjector(["normal", "uniform"], 3, 2, quadrature_points=3)
    rng = np.random.default_rng(8)
    d = 2
    order = pr.block_order(d)
    assert sorted(order) == list(np.flatnonzero(pr.state_mask(d)))
    A = pr.matrix(rng.normal(size=(pr.nodes.shape[0], d, d)), order)
    groups = identical_block_groups(A)
    n_par_terms = len(np.unique(pr.par[pr.excited & (pr.chaos.indices[:, 2:].sum(axis=1) == 0)]))
    assert sorted(g.shape for g in groups) == [(1, d * n_par_terms), (3, d * 3)]
    for g in groups:
        assert np.array_equal(g.ravel(), np.arange(g[0, 0], g[0, 0] + g.size))

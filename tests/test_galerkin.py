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


# -- every tensor against its definition by brute-force quadrature over all germs ---------------
def _orthonormal(dist, x, degree):
    """Orthonormal polynomials from numpy's classical ones (not the package's recurrences):
    He_n / sqrt(n!) for N(0, 1), sqrt(2n + 1) P_n for U(-1, 1)."""
    from math import factorial

    from numpy.polynomial import hermite_e, legendre

    if dist == "normal":
        return np.stack([hermite_e.hermeval(x, np.eye(degree + 1)[n]) / np.sqrt(factorial(n)) for n in range(degree + 1)], axis=-1)
    return np.stack([legendre.legval(x, np.eye(degree + 1)[n]) * np.sqrt(2 * n + 1) for n in range(degree + 1)], axis=-1)


def _gauss(dist, n):
    from numpy.polynomial import hermite_e, legendre

    x, w = hermite_e.hermegauss(n) if dist == "normal" else legendre.leggauss(n)
    return x, w / w.sum()


PAR, LIN, ORDER = ["normal", "uniform"], ["normal", "uniform"], 2


def _full_quadrature(pr):
    """Tensor Gauss rule over all 4 germs (5 points each: exact to degree 9 >= 2 ORDER + 2 + 1)
    and the basis phi_k at its nodes, (Q, P)."""
    rules = [_gauss(d, 5) for d in PAR + LIN]
    grids = np.meshgrid(*[r[0] for r in rules], indexing="ij")
    xi = np.stack([g.ravel() for g in grids], axis=1)
    w = np.prod(np.stack(np.meshgrid(*[r[1] for r in rules], indexing="ij")), axis=0).ravel()
    phi = np.ones((xi.shape[0], pr.n_terms))
    for j, d in enumerate(PAR + LIN):
        phi *= _orthonormal(d, xi[:, j], ORDER)[:, pr.chaos.indices[:, j]]
    return xi, w, phi


def _quadratic(coef, xi_p):
    """c0 + c1 xi_1 + c2 xi_2^2 for coefficient arrays c (3, ...): values (Q, ...)."""
    return coef[0] + xi_p[:, 0, None, None] * coef[1] + xi_p[:, 1, None, None] ** 2 * coef[2]


def test_every_projection_equals_its_definition_by_brute_force_quadrature():
    """A_PCE[iP+k, jP+l] = E[phi_k phi_l A_ij(xi_p)], E_PCE[iP+k, r] = E[phi_k E_ir(xi_p)],
    <phi_k F_j xi_j>, X(0) = <phi_k x0> and the linear initial state, each against a tensor Gauss
    rule over all four germs (parametric and linear), with orthonormal polynomials from numpy's
    classical families. A, E, F, x0 are quadratic in the parametric germs, so the projector's 4
    points per germ (exact to degree 7 >= 2 ORDER + 2) are exact: rel 1e-11 of the largest entry.
    Two leading derivative axes are kept; d = 3 states, r = 2 inputs (no shape can hide a
    transposition)."""
    pr = GalerkinProjector(PAR, LIN, ORDER, quadrature_points=4)
    xi, w, phi = _full_quadrature(pr)
    rng = np.random.default_rng(21)
    d, P = 3, pr.n_terms
    cA, cE, cF, cx = rng.normal(size=(3, 2, d, d)), rng.normal(size=(3, 2, d, 2)), rng.normal(size=(3, 2, d, 2)), rng.normal(size=(3, 2, d, 1))
    at_nodes = lambda c: np.moveaxis(_quadratic(np.moveaxis(c, 1, -1).reshape(3, c.shape[2], -1), pr.nodes).reshape(-1, c.shape[2], c.shape[3], 2), -1, 0)
    at_full = lambda c: np.moveaxis(_quadratic(np.moveaxis(c, 1, -1).reshape(3, c.shape[2], -1), xi[:, :2]).reshape(-1, c.shape[2], c.shape[3], 2), -1, 0)

    A_ref = np.einsum("q,qk,ql,aqij->aikjl", w, phi, phi, at_full(cA)).reshape(2, d * P, d * P)
    assert pr.matrix(at_nodes(cA)) == pytest.approx(A_ref, rel=1e-11, abs=1e-11 * np.abs(A_ref).max())
    E_ref = np.einsum("q,qk,aqir->aikr", w, phi, at_full(cE)).reshape(2, d * P, 2)
    assert pr.input_matrix(at_nodes(cE)) == pytest.approx(E_ref, rel=1e-11, abs=1e-11 * np.abs(E_ref).max())
    F_ref = np.einsum("q,qk,qj,aqij->aikj", w, phi, xi[:, 2:], at_full(cF)).reshape(2, d * P, 2)
    assert pr.linear_input_matrix(at_nodes(cF)) == pytest.approx(F_ref, rel=1e-11, abs=1e-11 * np.abs(F_ref).max())
    assert np.abs(F_ref[:, :, 1]).max() > 0.1  # the uniform germ's column (scale 1/sqrt(3)) is checked too
    x0_ref = np.einsum("q,qk,aqi->aik", w, phi, at_full(cx)[..., 0]).reshape(2, d * P)
    assert pr.initial_state(at_nodes(cx)[..., 0]) == pytest.approx(x0_ref, rel=1e-11, abs=1e-11 * np.abs(x0_ref).max())
    x0_lin_ref = np.einsum("q,qk,qj,qij->ik", w, phi, xi[:, 2:], at_full(cF)[0]).reshape(d * P)
    assert pr.linear_initial_state(at_nodes(cF)[0]) == pytest.approx(x0_lin_ref, rel=1e-11, abs=1e-11 * np.abs(x0_lin_ref).max())


def test_excited_terms_and_the_exactness_of_dropping_the_others():
    """The docstring's count: 4 normal + 7 linear germs at order 2 have 78 terms, 50 excited
    (linear order <= 1). Dropping the others is exact: the reduced response scattered back equals
    the full response (expm of the full system, rel 1e-12), zeros at the dropped states."""
    from scipy.linalg import expm

    big = GalerkinProjector(["normal"] * 4, 7, 2, quadrature_points=1)
    assert (big.n_terms, int(big.excited.sum())) == (78, 50)
    assert np.array_equal(big.excited, big.chaos.indices[:, 4:].sum(axis=1) <= 1)
    pr = GalerkinProjector(["normal", "uniform"], 2, 2, quadrature_points=3)
    rng = np.random.default_rng(22)
    Q, d = pr.nodes.shape[0], 2
    A = pr.matrix(-np.eye(d) + 0.3 * rng.normal(size=(Q, d, d)))
    X0 = pr.initial_state(rng.normal(size=(Q, d))) + pr.linear_initial_state(rng.normal(size=(Q, d, 2)))
    keep = pr.state_mask(d)
    assert keep.sum() < keep.size and np.array_equal(keep, np.tile(pr.excited, d))
    times = np.array([0.3, 1.0])
    full = np.stack([expm(A * t) @ X0 for t in times])
    reduced = np.stack([expm(A[np.ix_(keep, keep)] * t) @ X0[keep] for t in times])
    back = GalerkinProjector.scatter(reduced, keep)
    assert back.shape == full.shape and back == pytest.approx(full, rel=1e-12, abs=1e-14)
    assert np.all(back[:, ~keep] == 0.0) and np.abs(full[:, ~keep]).max() < 1e-14


def test_scatter_and_coefficients_layouts():
    """scatter keeps leading axes and returns the input itself when every state is kept;
    coefficients maps the state-major index i P + k to [i, k], keeping any leading axes."""
    mask = np.array([True, False, True, True, False])
    reduced = np.arange(12.0).reshape(2, 2, 3)
    full = GalerkinProjector.scatter(reduced, mask)
    assert full.shape == (2, 2, 5)
    assert np.array_equal(full[..., mask], reduced) and np.all(full[..., ~mask] == 0)
    same = np.ones((2, 5))
    assert GalerkinProjector.scatter(same, np.ones(5, bool)) is same
    pr = GalerkinProjector(["normal"], 1, 2, quadrature_points=2)
    P = pr.n_terms
    X = np.arange(2 * 3 * P, dtype=float).reshape(2, 3 * P)
    c = pr.coefficients(X)
    assert c.shape == (2, 3, P) and c[1, 2, P - 1] == X[1, 2 * P + P - 1] and c[0, 1, 0] == X[0, P]
    S = np.arange(2 * 4 * 3 * P, dtype=float).reshape(2, 4, 3 * P)  # sensitivities: (time, parameter, d P)
    assert pr.coefficients(S).shape == (2, 4, 3, P) and pr.coefficients(S)[1, 3, 2, 1] == S[1, 3, 2 * P + 1]


def test_block_order_without_linear_germs_and_defaults():
    """No linear germs: one block, the state-major order itself. Thesis default: 4 Gauss points
    per parametric germ; one point is a valid rule, a negative count of linear germs is not."""
    pr = GalerkinProjector(["normal", "uniform"], 0, 2)
    assert pr.nodes.shape == (16, 2) and pr.weights.sum() == pytest.approx(1.0, rel=1e-14)
    assert np.array_equal(pr.block_order(3), np.arange(3 * pr.n_terms))
    assert pr.g_lin.shape == (0, pr.n_terms, 16)
    assert GalerkinProjector(["normal"], 0, 1, quadrature_points=1).nodes.shape == (1, 1)
    with pytest.raises(ValueError, match="n_linear must be non-negative"):
        GalerkinProjector(["normal"], -1, 2)

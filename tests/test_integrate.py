import numpy as np
import pytest

from uqdrive.numerics.integrate import _foh_block, decoupled_blocks, foh_discretise, foh_discretise_single, lti_foh_response, rk4_fixed_step


def test_foh_is_exact_for_a_ramp():
    """x' = a x + t, x(0) = 0 has x = (e^{at} - 1 - a t) / a^2; FOH is exact for linear inputs."""
    a = np.array([-3.0, 0.5])
    A = a[:, None, None]
    E = np.ones((2, 1, 1))
    h, S, K = 0.1, 4, 10
    t_fine = np.arange(K * S + 1) * h
    x = lti_foh_response(A, E, t_fine[:, None], h, S)
    t = t_fine[::S]
    exact = (np.exp(np.outer(t, a)) - 1 - np.outer(t, a)) / a**2
    assert x[0].T == pytest.approx(exact, rel=1e-12, abs=1e-14)


def test_foh_discretise_zero_order_parts():
    """For a constant input the FOH maps P + Q equal the ZOH input matrix A^-1 (Phi - I) E."""
    rng = np.random.default_rng(0)
    A = rng.normal(size=(3, 4, 4)) - 3 * np.eye(4)
    E = rng.normal(size=(3, 4, 2))
    Phi, P, Q = foh_discretise(A, E, 0.05)
    zoh = np.linalg.solve(A, (Phi - np.eye(4)) @ E)
    assert P + Q == pytest.approx(zoh, rel=1e-10, abs=1e-12)


def test_lti_response_matches_matrix_exponential_with_initial_state():
    A = np.array([[[0.0, 1.0], [-4.0, -0.4]]])
    E = np.zeros((1, 2, 1))
    x0 = np.array([[1.0, 0.0]])
    x = lti_foh_response(A, E, np.zeros((21, 1)), 0.05, 2, x0)
    from scipy.linalg import expm

    assert x[:, 0, -1] == pytest.approx(expm(A[0] * 1.0) @ x0[0], rel=1e-12)


def test_rk4_has_fourth_order_convergence():
    def rhs(x, j):
        return -x

    errors = []
    for n in (10, 20, 40):
        out = rk4_fixed_step(rhs, np.ones((1, 1)), 1.0 / n, n, n)
        errors.append(abs(out[-1, 0, 0] - np.exp(-1.0)))
    order = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert order == pytest.approx([4.0, 4.0], abs=0.1)


def test_rk4_passes_half_step_indices():
    seen = []

    def rhs(x, j):
        seen.append(j)
        return np.zeros_like(x)

    rk4_fixed_step(rhs, np.zeros((1, 1)), 0.1, 2, 1)
    assert seen == [0, 1, 1, 2, 2, 3, 3, 4]


def _block_system(rng, shared: bool, permute: bool = True):
    """Three decoupled 3x3 blocks (two identical if ``shared``), permuted (or consecutive), with
    4 inputs of which each block sees only some."""
    blocks = [rng.normal(size=(3, 3)) - 2 * np.eye(3) for _ in range(3)]
    if shared:
        blocks[2] = blocks[1].copy()
    A = np.zeros((9, 9))
    E = np.zeros((9, 4))
    for b, M in enumerate(blocks):
        A[3 * b : 3 * b + 3, 3 * b : 3 * b + 3] = M
    E[0:3, 0] = rng.normal(size=3)
    E[3:6, 1:3] = rng.normal(size=(3, 2))
    E[6:9, 3] = rng.normal(size=3)
    perm = rng.permutation(9) if permute else np.arange(9)
    return A[np.ix_(perm, perm)], E[perm], perm


@pytest.mark.parametrize("permute", [True, False])
@pytest.mark.parametrize("shared", [False, True])
def test_block_discretisation_equals_the_whole_exponential(shared, permute):
    """Decoupled (and identical) blocks, scattered or consecutive (sliced, not fancy-indexed),
    discretised apart give the maps of the full Van Loan exponential to round-off (1e-13)."""
    rng = np.random.default_rng(3)
    A, E, _ = _block_system(rng, shared, permute)
    assert len(decoupled_blocks(A != 0)) == 3
    for split, whole in zip(foh_discretise_single(A, E, 0.05), _foh_block(A, E, 0.05)):
        assert split == pytest.approx(whole, rel=1e-13, abs=1e-14)


@pytest.mark.parametrize("permute", [True, False])
def test_block_discretisation_derivatives_equal_the_whole_frechet(permute):
    rng = np.random.default_rng(4)
    A, E, _ = _block_system(rng, shared=False, permute=permute)
    dA = np.stack([A * rng.normal(), (A != 0) * rng.normal(size=A.shape)])
    dE = np.stack([E * rng.normal(), (E != 0) * rng.normal(size=E.shape)])
    split = foh_discretise_single(A, E, 0.05, dA, dE)
    whole = _foh_block(A, E, 0.05, dA, dE)
    for a, b in zip(split[0] + split[1], whole[0] + whole[1]):
        assert a == pytest.approx(b, rel=1e-12, abs=1e-13)


@pytest.mark.parametrize("direction_scale", [1.0, 1e6])
def test_input_only_directions_equal_the_frechet_derivative(direction_scale):
    """Derivatives of Phi, P, Q (from the block-triangular sensitivity system) equal scipy's
    Frechet derivative of the Van Loan block (1e-12), with dPhi exactly 0 for a direction that
    moves only E. A direction a million times larger than A (a gain's derivative against a
    stiffness) must cost no accuracy: unscaled, it would set the doublings and miss by 1e-11."""
    from scipy.linalg import expm_frechet

    from uqdrive.numerics.adjoint import _van_loan_input_block

    def _split_van_loan(F, d, r, h):
        Q = F[..., :d, d + r :] / h
        return F[..., :d, :d], F[..., :d, d : d + r] - Q, Q

    rng = np.random.default_rng(5)
    A = rng.normal(size=(5, 5)) - 2 * np.eye(5)
    E = rng.normal(size=(5, 2))
    dA = np.stack([np.zeros((5, 5)), rng.normal(size=(5, 5)), np.zeros((5, 5))]) * direction_scale
    dE = rng.normal(size=(3, 5, 2)) * direction_scale
    h = 0.05
    _, (dPhi, dP, dQ) = _foh_block(A, E, h, dA, dE)
    M = _van_loan_input_block(A, E, h)
    for p in range(3):
        dM = np.zeros_like(M)
        dM[:5, :5], dM[:5, 5:7] = dA[p] * h, dE[p] * h
        ref = _split_van_loan(expm_frechet(M, dM, compute_expm=False), 5, 2, h)
        for got, want in zip((dPhi[p], dP[p], dQ[p]), ref):
            assert got == pytest.approx(want, rel=1e-12, abs=1e-13)
    assert not np.any(dPhi[[0, 2]])


@pytest.mark.parametrize("scale", [0.05, 10.0, 60.0])  # ||A h||_1 about 0.004, 0.8, 5 (uqdrive's cars: up to 5.4): 0, 1, 4 doublings
def test_foh_maps_equal_van_loans_exponential_with_and_without_doublings(scale):
    """Phi, P, Q against scipy's expm of Van Loan's block [[A h, E h, 0], [0, 0, I h], [0, 0, 0]]
    (independent of foh_discretise's phi-function series and its doublings of the step, which
    each scale exercises: none, one, several). Tolerance: a few hundred ulps of the largest entry,
    the rounding of ~20 products; a wrong coefficient of the series, or the series cut
    a few terms short, misses by far more."""
    from scipy.linalg import expm

    from uqdrive.numerics import discretise

    rng = np.random.default_rng(3)
    A, E, h = rng.normal(size=(20, 4, 4)) * scale, rng.normal(size=(20, 4, 3)), 0.01
    rho = np.abs(A * h).sum(axis=-2).max()
    assert (rho <= discretise._PHI_TAYLOR_NORM) == (scale < 1)
    Phi, P, Q = foh_discretise(A, E, h)
    for j in range(A.shape[0]):
        M = np.zeros((10, 10))
        M[:4, :4], M[:4, 4:7], M[4:7, 7:] = A[j] * h, E[j] * h, np.eye(3) * h
        F = expm(M)
        Qr = F[:4, 7:] / h
        for got, ref in ((Phi[j], F[:4, :4]), (P[j], F[:4, 4:7] - Qr), (Q[j], Qr)):
            assert np.abs(got - ref).max() <= 5e-14 * np.abs(ref).max()


def test_foh_step_maps_cache_hits_bit_for_bit_and_misses_on_a_change():
    """The kept step maps of a stack of A give the very bits of a fresh computation, with any E;
    a changed entry of A (or another h) is computed anew; the cache stays bounded and a caller
    writing into the returned Phi leaves the kept maps alone."""
    from uqdrive.numerics import discretise

    rng = np.random.default_rng(3)
    A = rng.normal(size=(5, 4, 4)) * 40.0 - 30.0 * np.eye(4)  # norms that need doublings at h
    E1, E2 = rng.normal(size=(5, 4, 3)), rng.normal(size=(5, 4, 3))
    h = 0.01
    discretise._STEP_MAPS.clear()
    fresh = [foh_discretise(A, E, h) for E in (E1, E2)]
    for E, want in zip((E1, E2), fresh):
        discretise._STEP_MAPS.clear()
        got = foh_discretise(A, E, h)
        assert all(np.array_equal(g, w) for g, w in zip(got, want))
    hit = foh_discretise(A, E1, h)  # A kept from the loop: a hit
    assert len(discretise._STEP_MAPS) == 1
    assert all(np.array_equal(g, w) for g, w in zip(hit, fresh[0]))
    hit[0][:] = 0.0  # the caller's copy only
    assert np.array_equal(foh_discretise(A, E1, h)[0], fresh[0][0])
    B = A.copy()
    B[2, 1, 0] += 1.0
    changed = foh_discretise(B, E1, h)
    assert len(discretise._STEP_MAPS) == 2
    assert not np.array_equal(changed[0][2], fresh[0][0][2]) and np.array_equal(changed[0][0], fresh[0][0][0])
    foh_discretise(A, E1, 2 * h)
    assert len(discretise._STEP_MAPS) == 3
    for k in range(2 * discretise._STEP_MAPS_ENTRIES):
        foh_discretise(A + k, E1, h)
    assert len(discretise._STEP_MAPS) == discretise._STEP_MAPS_ENTRIES

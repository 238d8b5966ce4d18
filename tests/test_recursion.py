import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from uqdrive.numerics.recursion import decoupled_blocks, identical_block_groups, linear_recursion, reverse_linear_recursion


def _loop(Phi, drive, x0):
    x = [x0]
    for d in drive:
        x.append(x[-1] @ Phi.T + d)
    return np.array(x)


def _stable(rng, n, radius=0.95):
    M = rng.normal(size=(n, n))
    return radius * M / np.max(np.abs(np.linalg.eigvals(M)))


@settings(max_examples=40, deadline=None)
@given(K=st.integers(1, 300), n=st.integers(1, 7), batch=st.sampled_from([(), (1,), (3,), (2, 2)]), seed=st.integers(0, 2**16))
def test_chunked_recursion_equals_the_step_by_step_loop(K, n, batch, seed):
    """Any number of steps (chunk sizes that do and do not divide K), batch axes and x0: the
    chunked evaluation sums the same terms in another order, equal to 1e-12 relative."""
    rng = np.random.default_rng(seed)
    Phi = _stable(rng, n)
    drive = rng.normal(size=(K,) + batch + (n,))
    x0 = rng.normal(size=batch + (n,))
    want = _loop(Phi, drive, x0)
    got = linear_recursion(Phi, drive, x0)
    assert got.shape == (K + 1,) + batch + (n,)
    assert got == pytest.approx(want, rel=1e-12, abs=1e-12 * np.abs(want).max())


def test_integrator_chains_stay_exact():
    """Marginally stable Phi (a double integrator, powers grow linearly): still the loop's
    numbers to 1e-12 over 1000 steps."""
    h = 0.01
    Phi = np.array([[1.0, 0.0], [h, 1.0]])
    drive = np.random.default_rng(0).normal(size=(1000, 2))
    want = _loop(Phi, drive, np.ones(2))
    assert linear_recursion(Phi, drive, np.ones(2)) == pytest.approx(want, rel=1e-12, abs=1e-12 * np.abs(want).max())


@pytest.mark.parametrize("merge", [True, False])
def test_block_groups_and_identical_blocks(merge, monkeypatch):
    """Three decoupled blocks, two of them identical, in a permuted order: two groups, the
    recursion by groups (or, for blocks this small, as one merged dense system) equals the
    dense loop."""
    import uqdrive.numerics.recursion

    if not merge:
        monkeypatch.setattr(uqdrive.numerics.recursion, "_GROUP_OVERHEAD_FLOPS", 0.0)
    rng = np.random.default_rng(1)
    B1, B2 = _stable(rng, 3), _stable(rng, 2)
    Phi = np.zeros((7, 7))
    Phi[:3, :3], Phi[3:5, 3:5], Phi[5:, 5:] = B1, B2, B2
    perm = rng.permutation(7)
    Phi = Phi[np.ix_(perm, perm)]
    assert sorted(len(b) for b in decoupled_blocks(Phi != 0)) == [2, 2, 3]
    groups = identical_block_groups(Phi)
    assert sorted(g.shape for g in groups) == [(1, 3), (2, 2)]
    drive = rng.normal(size=(200, 4, 7))
    x0 = rng.normal(size=(4, 7))
    assert linear_recursion(Phi, drive, x0, groups) == pytest.approx(_loop(Phi, drive, x0), rel=1e-12, abs=1e-12)


def test_reverse_recursion_is_the_adjoint():
    """<G, x> = <lambda_0, x0> + sum_k <lambda_{k+1}, d_k> for x from linear_recursion: the
    reverse recursion is its transpose (to round-off)."""
    rng = np.random.default_rng(2)
    Phi = _stable(rng, 5)
    drive, x0, G = rng.normal(size=(150, 5)), rng.normal(size=5), rng.normal(size=(151, 5))
    x = linear_recursion(Phi, drive, x0)
    lam = reverse_linear_recursion(Phi, G)
    assert np.sum(G * x) == pytest.approx(lam[0] @ x0 + np.sum(lam[1:] * drive), rel=1e-12)


def test_zero_steps_returns_the_initial_state():
    out = linear_recursion(np.eye(2), np.zeros((0, 2)), np.array([1.0, 2.0]))
    assert out.tolist() == [[1.0, 2.0]]


@pytest.mark.parametrize("merge", [True, False])
def test_in_place_recursion_on_a_strided_view(merge, monkeypatch):
    """The drive may sit in a column slice of a larger array (a block of a block-ordered state):
    the states are written there and nowhere else, by blocks or merged."""
    import uqdrive.numerics.recursion
    from uqdrive.numerics.recursion import linear_recursion_in_place

    if not merge:
        monkeypatch.setattr(uqdrive.numerics.recursion, "_GROUP_OVERHEAD_FLOPS", 0.0)

    rng = np.random.default_rng(3)
    Phi = np.zeros((9, 9))
    Phi[:4, :4], Phi[4:, 4:] = _stable(rng, 4), _stable(rng, 5)
    drive, x0 = rng.normal(size=(300, 2, 9)), rng.normal(size=(2, 9))
    big = rng.normal(size=(301, 2, 12))
    before = big.copy()
    view = big[..., 2:11]
    view[0], view[1:] = x0, drive
    linear_recursion_in_place(Phi, view)
    assert big[..., 2:11] == pytest.approx(_loop(Phi, drive, x0), rel=1e-12, abs=1e-12 * np.abs(big).max())
    assert np.array_equal(big[..., :2], before[..., :2]) and np.array_equal(big[..., 11:], before[..., 11:])

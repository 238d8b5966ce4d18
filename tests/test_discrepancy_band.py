"""The null band: sampling scales of the moment statistics, the scan statistic's calibration and
the linearised refit of bootstrap replicates."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from uqdrive.inference.discrepancy.band import NullBand, excess_rms, moment_statistics, refit_projection, replicate_statistics, scan, scan_windows, statistic_scale
from uqdrive.inference.discrepancy.catchall import smooth_discrepancy


def test_statistic_scale_matches_the_spread_of_repeated_estimates():
    """Gaussian and uniform states: the predicted sd of the mean (s/sqrt n) and of the std (delta
    method with m4) match the spread over 400 repetitions within 15 % (the sd of an sd estimate
    from 400 draws is ~3.5 %; the delta method's O(1/n) bias at n = 200 is ~1 %)."""
    rng = np.random.default_rng(0)
    n, reps = 200, 400
    index = np.arange(3)
    for draw in (lambda size: rng.standard_normal(size), lambda size: rng.uniform(-1, 1, size)):
        stats = np.array([moment_statistics(draw((4, n, 3)), index) for _ in range(reps)])
        predicted = statistic_scale(draw((4, 20000, 3)), index) * np.sqrt(20000 / n)
        assert np.allclose(stats.std(axis=0, ddof=1) / predicted, 1.0, atol=0.15)
    uniform_std_scale = statistic_scale(rng.uniform(-1, 1, (1, 20000, 1)), [0])[1, 0, 0]
    gaussian_std_scale = statistic_scale(rng.normal(0, 1 / np.sqrt(3), (1, 20000, 1)), [0])[1, 0, 0]
    assert uniform_std_scale < 0.75 * gaussian_std_scale  # platykurtic: the Gaussian formula would be wrong


def test_model_ratio_adds_the_models_own_error():
    x = np.random.default_rng(1).standard_normal((4, 100, 5))
    assert np.allclose(statistic_scale(x, np.arange(5), model_ratio=1.0), np.sqrt(2) * statistic_scale(x, np.arange(5)))


@given(st.integers(2, 300))
@settings(max_examples=30, deadline=None)
def test_scan_windows_cover_every_point_and_the_whole_horizon(K):
    w = scan_windows(K)
    assert w.min() == 0 and w.max() == K and np.all(w[:, 1] > w[:, 0])
    assert any((a, b) == (0, K) for a, b in w)
    covered = np.zeros(K, bool)
    for a, b in w[w[:, 1] - w[:, 0] == 1]:
        covered[a:b] = True
    assert covered.all()


def test_scan_sums_windows():
    z = np.arange(10.0).reshape(1, 1, 10)
    cells = scan(z, np.array([[0, 4], [3, 10]]))
    assert np.allclose(cells[0, 0], [6 / 2, 42 / np.sqrt(7)])


def test_family_wise_level_holds_on_independent_null_replicates():
    """Calibrated on 400 null replicates, the threshold is exceeded by about 5 % of 2000 fresh
    ones (binomial sd 0.5 %; the quantile of 400 maxima adds ~1 %): between 2 % and 9 %."""
    rng = np.random.default_rng(2)
    K = 60
    smooth = np.exp(-0.5 * (np.subtract.outer(np.arange(K), np.arange(K)) / 4.0) ** 2)
    L = np.linalg.cholesky(smooth + 1e-9 * np.eye(K))
    draw = lambda b: (rng.standard_normal((b, 2, 4, K)) @ L.T)  # noqa: E731  correlated in time
    band = NullBand.from_replicates(draw(400), scan_windows(K))
    fresh = draw(2000)
    rate = np.mean([band.max_statistic(z) > band.threshold for z in fresh])
    assert 0.02 <= rate <= 0.09
    assert band.inflation > 3  # correlation in time inflates parameter errors; 1 would be iid
    shifted = fresh[0].copy()
    shifted[0, 1, 20:40] += 4.0  # a local gap of 4 band units over a third of the horizon
    assert band.max_statistic(shifted) > band.threshold and band.p_value(shifted) < 0.05


def test_refit_projection_removes_what_the_parameters_can_mimic():
    rng = np.random.default_rng(3)
    J = rng.standard_normal((2 * 4 * 10, 3))
    z = rng.standard_normal((5, 2, 4, 10))
    p = refit_projection(z, J)
    assert np.allclose(p.reshape(5, -1) @ J, 0.0, atol=1e-10)
    assert np.allclose(refit_projection(z + (J @ rng.standard_normal(3)).reshape(2, 4, 10), J), p)


def test_excess_rms_is_zero_at_the_null_level_and_grows_with_a_gap():
    rng = np.random.default_rng(4)
    band = NullBand.from_replicates(rng.standard_normal((200, 2, 4, 30)), scan_windows(30))
    assert excess_rms(rng.standard_normal((2, 4, 30)) * 0.9, band) == 0.0
    assert excess_rms(rng.standard_normal((2, 4, 30)) + 2.0, band) == pytest.approx(2.0, abs=0.3)


def test_catch_all_absorbs_a_smooth_gap_but_not_white_noise():
    rng = np.random.default_rng(5)
    t = np.linspace(0, 1, 100)
    smooth = np.broadcast_to(3 * np.sin(2 * np.pi * t), (2, 4, 100))
    resid, p = smooth_discrepancy(smooth)
    assert p == 64 and np.abs(resid).max() < 0.05
    noise = rng.standard_normal((2, 4, 100))
    assert np.sum(smooth_discrepancy(noise)[0] ** 2) > 0.8 * np.sum(noise**2)


def test_replicate_statistics_equal_the_one_replicate_functions():
    """The null band's one-pass statistics of R replicates equal moment_statistics and
    statistic_scale per replicate (rel 1e-10: the same sums in another order), for heavy-tailed
    data (the fourth moment matters), a model ratio and a state that does not vary (the floor)."""
    rng = np.random.default_rng(4)
    x = rng.standard_t(5, (4, 3, 50, 6))
    x[1, :, :, 0] = 2.0  # no spread at the first time: the floor decides the scale there
    stats, scale = replicate_statistics(x, model_ratio=0.5)
    assert stats.shape == scale.shape == (3, 2, 4, 6)
    k = np.arange(6)
    for r in range(3):
        assert stats[r] == pytest.approx(moment_statistics(x[:, r], k), rel=1e-10, abs=1e-12)
        assert scale[r] == pytest.approx(statistic_scale(x[:, r], k, model_ratio=0.5), rel=1e-10)
    assert not np.allclose(scale[0], scale[1])  # replicates are not mixed up
    assert np.all(np.isfinite(scale)) and np.all(scale > 0)  # the floor, not 0 / 0, at the constant state

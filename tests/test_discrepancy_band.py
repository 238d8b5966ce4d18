"""The null band: sampling scales of the moment statistics, the scan statistic's calibration and
the linearised refit of bootstrap replicates."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from uqdrive.inference.discrepancy.band import NullBand, excess_rms, moment_statistics, refit_projection, replicate_statistics, scan, scan_windows, statistic_scale
from uqdrive.inference.discrepancy.verdict import smooth_discrepancy


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
    # exact: a null level of 1 and z = -+3 everywhere: sqrt(9 - 1)
    for z in (3.0, -3.0):
        assert excess_rms(np.full((2, 4, 3), z), _band([1.0, 2.0], [0.0, 1.0])) == pytest.approx(np.sqrt(8.0), rel=1e-12)


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


def test_moments_and_scales_have_their_textbook_values():
    """x = 1, 2, 3, 4 at one time: mean 2.5, std (ddof 1) sqrt(5/3); Gaussian s = 2, m4 = 3 s^4,
    n = 50: sd of the mean s / sqrt(n) = 0.2828, of the std s / sqrt(2 n) = 0.2; a time without
    spread takes the floor 1e-3 x the largest scale of its statistic and state."""
    from uqdrive.inference.discrepancy.band import _scale_of_moments, compared_times, mean_std, standardised_gap

    x = np.broadcast_to(np.array([1.0, 2.0, 3.0, 4.0])[None, :, None], (4, 4, 1))
    np.testing.assert_allclose(mean_std(x)[:, 0, 0], [2.5, np.sqrt(5.0 / 3.0)], rtol=1e-14)
    s, m4 = np.array([0.0, 2.0]), np.array([0.0, 48.0])
    scale = _scale_of_moments(s, m4, 50, 0.0, 1e-3)
    np.testing.assert_allclose(scale, [[2e-3 / np.sqrt(50), 2 / np.sqrt(50)], [0.2e-3, 0.2]], rtol=1e-12)
    np.testing.assert_allclose(_scale_of_moments(s, m4, 50, 3.0, 1e-3), 2.0 * scale, rtol=1e-12)  # sqrt(1 + 3)
    np.testing.assert_array_equal(_scale_of_moments(np.zeros(2), np.zeros(2), 50, 0.0, 1e-3), 1e-3)  # nothing varies: the floor x 1
    xs = np.arange(2 * 3 * 6, dtype=float).reshape(2, 3, 6)[None].repeat(4, 0)[:, 0]
    assert np.shares_memory(compared_times(xs, np.arange(2, 5)), xs)  # consecutive times: a view
    np.testing.assert_array_equal(compared_times(xs, np.arange(2, 5)), xs[:, :, 2:5])
    np.testing.assert_array_equal(compared_times(xs, np.array([0, 2, 5])), xs[:, :, [0, 2, 5]])
    np.testing.assert_array_equal(standardised_gap([3.0, 1.0], [1.0, 2.0], [2.0, 0.5]), [1.0, -2.0])
    z = np.ones((1, 2, 4, 3))
    assert refit_projection(z, np.empty((24, 0))) is not None and np.array_equal(refit_projection(z, np.empty((24, 0))), z)


def test_scan_windows_of_five_points():
    """Lengths 1, 4 (half-overlap, the last window pinned to the end) and the whole horizon 5."""
    assert scan_windows(5).tolist() == [[0, 1], [0, 4], [0, 5], [1, 2], [1, 5], [2, 3], [3, 4], [4, 5]]


def _band(max_null, chi2_null, level=0.05, K=3):
    windows = scan_windows(K)
    return NullBand(windows, np.ones((2, 4, len(windows))), np.asarray(max_null, float), 1.0, float(np.std(chi2_null, ddof=1)), 1.0, level,
                    np.asarray(chi2_null, float))


def test_threshold_and_p_value_follow_the_gumbel_fit_of_the_maxima():
    """Maxima with mean 3 and sd pi / sqrt(6): Gumbel scale 1, location 3 - 0.5772; the 0.95
    quantile is loc - log(-log 0.95) = 5.3930; at z's maximum = loc the p-value is 1 - 1/e."""
    m = np.array([3.0 - np.pi / np.sqrt(6), 3.0 + np.pi / np.sqrt(6)])  # sd (ddof 1) pi/sqrt(6) * sqrt(2)
    m = 3.0 + (m - 3.0) / np.sqrt(2)
    band = _band(m, [0.0, 1.0])
    loc = 3.0 - 0.5772156649015329
    assert band.threshold == pytest.approx(loc - np.log(-np.log(0.95)), rel=1e-12)
    assert _band(m, [0.0, 1.0], level=0.01).threshold == pytest.approx(loc - np.log(-np.log(0.99)), rel=1e-12)
    default = NullBand(band.windows, band.cell_scale, band.max_null, 1.0, 1.0, 1.0)  # level not given: 0.05
    assert default.level == 0.05 and default.threshold == pytest.approx(band.threshold, rel=1e-12)
    z = np.zeros((2, 4, 3))
    z[1, 2, 1] = loc  # the length-1 window at time 1 is the largest cell
    assert band.max_statistic(z) == pytest.approx(loc)
    assert band.p_value(z) == pytest.approx(1.0 - np.exp(-1.0), rel=1e-12)
    z[1, 2, 1] = -2 * loc  # the absolute value counts
    assert band.max_statistic(z) == pytest.approx(2 * loc)


def test_the_gate_needs_both_a_scan_crossing_and_an_excess_misfit():
    """mean_square_null 1, chi2 null sd 1 (replicates 0, sqrt 2): excess misfit must exceed 2."""
    band = _band(np.linspace(1.0, 2.0, 50), [0.0, np.sqrt(2.0)])
    thr = band.threshold
    z = np.zeros((2, 4, 3))
    assert band.excess_chi2(z) == pytest.approx(-24.0)  # sum 0 minus 24 cells at level 1
    assert band.excess_chi2(np.full((2, 4, 3), -1.5)) == pytest.approx(24 * 2.25 - 24.0)  # squares: the sign does not count
    z[0, 0, 0] = thr + 0.1  # crosses the scan, excess (thr + 0.1)^2 - 24 < 2
    assert band.max_statistic(z) > thr and not band.gate(z)
    spread = np.full((2, 4, 3), 1.1)  # no cell crosses (1.1 sqrt(3) = 1.91 < thr = 2.06), excess 24 x 0.21 > 2
    assert band.max_statistic(spread) < thr and band.excess_chi2(spread) > 2 and not band.gate(spread)
    both = spread.copy()
    both[0, 0, 0] = thr + 0.1
    assert band.gate(both)


def test_false_alarm_rate_counts_replicates_past_both_gates():
    """Four replicates, maxima 1, 9, 9, 9, chi2 0, 0, 0, 10 (mean 2.5) and a chi2 null sd of 1: at
    level 0.05 the Gumbel threshold (~14.5) is above every maximum, rate 0; at level 0.9 it falls
    between 1 and 9 and of the three crossing replicates only the last has an excess chi2 above
    2 sd (10 - 2.5 > 2): rate 1/4."""
    windows = scan_windows(3)
    base = dict(windows=windows, cell_scale=np.ones((2, 4, len(windows))), mean_square_null=1.0, inflation=1.0, level=0.05)
    chi2 = np.array([0.0, 0.0, 0.0, 10.0])
    band = NullBand(max_null=np.array([1.0, 9.0, 9.0, 9.0]), chi2_null_sd=1.0, chi2_null=chi2, **base)
    assert band.false_alarm_rate() == 0.0
    low = NullBand(max_null=np.array([1.0, 9.0, 9.0, 9.0]), chi2_null_sd=1.0, chi2_null=chi2, **{**base, "level": 0.9})
    assert 1.0 < low.threshold < 9.0
    assert low.false_alarm_rate() == 0.25
    assert np.isnan(NullBand(max_null=np.ones(4), chi2_null_sd=1.0, chi2_null=None, **base).false_alarm_rate())  # NaN without chi2


def test_from_replicates_golden_level_spread_and_inflation():
    """z constant in time (perfectly correlated): Var(sum z) = K^2 var, sum Var = K var, inflation
    K; iid z: about 1. mean_square_null = mean z^2; chi2_null_sd = sd of the replicates' sums."""
    rng = np.random.default_rng(7)
    K = 6
    a = rng.standard_normal((300, 2, 4, 1))
    band = NullBand.from_replicates(np.repeat(a, K, axis=-1), scan_windows(K))
    assert band.inflation == pytest.approx(K, rel=1e-9)
    iid = rng.standard_normal((300, 2, 4, K))
    band = NullBand.from_replicates(iid, scan_windows(K))
    assert band.inflation == pytest.approx(1.0, abs=0.3)
    assert band.mean_square_null == pytest.approx(np.mean(iid**2), rel=1e-12)
    chi2 = np.sum(iid**2, axis=(1, 2, 3))
    assert band.chi2_null_sd == pytest.approx(np.std(chi2, ddof=1), rel=1e-12)
    np.testing.assert_allclose(band.chi2_null, chi2)
    cells = scan(iid, scan_windows(K))
    np.testing.assert_allclose(band.cell_scale, cells.std(axis=0, ddof=1), rtol=1e-12)
    np.testing.assert_allclose(band.max_null, np.abs(cells / band.cell_scale).reshape(300, -1).max(axis=1), rtol=1e-12)
    assert band.level == 0.05
    # a cell that never varies keeps scale 1 (no division by 0)
    flat = iid.copy()
    flat[:, 0, 0, :] = 0.0
    assert np.all(NullBand.from_replicates(flat, scan_windows(K)).cell_scale[0, 0] == 1.0)


class _Germs:
    """Stand-in germs: n x d standard normals (only ``draw`` and ``kle`` are used by the bootstrap)."""

    def __init__(self, kle):
        self.kle = kle

    @classmethod
    def draw(cls, rng, n, n_modes):
        return cls(rng.standard_normal((n, n_modes)))


class _Recording:
    """A stand-in simulator: realisation i of a call is a + b G_i (theta = [a, b]) over 4 channels and 8
    times (G_i the germs reshaped to (4, 8)), beta (row 2) set to +-1e3 (alternately) at time 3 for
    the realisations whose running number over all calls is in ``spun``. Records every output."""

    channels, spin_row = ("psi", "psi_dot", "beta", "y"), 2

    def __init__(self, spun=()):
        self.germs = _Germs(np.zeros((1, 4 * 8)))
        self.spun, self.calls, self._count = set(spun), [], 0

    def simulate(self, theta, structure, germs):
        m = germs.kle.shape[0]
        x = theta[0] + theta[1] * germs.kle.reshape(m, 4, 8).transpose(1, 0, 2)
        hit = [i for i in range(m) if self._count + i in self.spun]
        x[2, hit, 3] = 1e3 * (-1.0) ** np.arange(len(hit))
        self._count += m
        self.calls.append(x)
        return x


def _replicate_chi2(calls, n, index, spin, statistics, J):
    """sum z^2 of each replicate from the recorded realisations, by the one-replicate functions:
    z = (statistics - the model's) / scale (model ratio 0.5) over the replicate's realisations,
    those with |beta| > spin at a compared time left out unless fewer than 2 would remain, then
    minus its least-squares fit by J's columns (the linearised refit)."""
    xs = np.concatenate(calls, axis=1)[:, :, index]
    k = np.arange(index.size)
    z = []
    for r in range(xs.shape[1] // n):
        block = xs[:, r * n:(r + 1) * n]
        keep = np.ones(n, bool) if spin is None else ~np.any(np.abs(block[2]) > spin, axis=-1)
        block = block[:, keep] if keep.sum() >= 2 else block
        z.append(((moment_statistics(block, k) - statistics) / statistic_scale(block, k, model_ratio=0.5)).ravel())
    z = np.array(z)
    z -= (J @ np.linalg.lstsq(J, z.T, rcond=None)[0]).T
    return np.sum(z**2, axis=1), np.mean(z**2)


def test_the_bootstrap_band_is_the_band_of_replicates_of_the_fitted_model():
    """5 replicates of n = 1500 realisations: at most 4000 realisations per simulation, so whole
    replicates 2 + 2 + 1. Without noise every replicate's z is exactly (its statistics - the
    model's) / its own scale from its n realisations (:func:`_replicate_chi2`), with the spun ones
    left out as in the data: replicate 0 none spun, 1 three (beta 1e3, -1e3, 1e3: |beta| counts),
    2 all but 2 (the 2 kept), 3 all but 1 (then all are used), 4 one; without a spin threshold
    all are used. The band's replicate chi2 are the sums of those z^2 (rel 1e-9: the same sums
    in another order)."""
    from uqdrive.inference.discrepancy.band import band_of_replicates, bootstrap_replicates

    n, B, index = 1500, 5, np.array([1, 2, 3, 4, 6, 7])  # the spin time 3 compared; times 0 and 5 not
    spun = [1500, 1501, 1502, *range(3000, 4498), *range(4500, 5999), 6007]
    J = np.random.default_rng(8).standard_normal((2 * 4 * 6, 2))
    base = type("Base", (), dict(theta_=np.array([0.5, 2.0]), structure_=None, jacobian_=J,
                                 statistics_=np.stack([np.full((4, 6), 0.5), np.full((4, 6), 2.0)])))()
    for spin in (100.0, None):
        sim = _Recording(spun)
        band = band_of_replicates(bootstrap_replicates(sim, base, n, index, np.zeros(4), spin, 0.5, np.random.default_rng(9), B), base, 0.05)
        assert [x.shape[1] for x in sim.calls] == [3000, 3000, 1500]
        chi2, mean_square = _replicate_chi2(sim.calls, n, index, spin, base.statistics_, J)
        np.testing.assert_allclose(band.chi2_null, chi2, rtol=1e-9)
        assert band.mean_square_null == pytest.approx(mean_square, rel=1e-9)
        np.testing.assert_array_equal(band.windows, scan_windows(6))
        assert band.level == 0.05
    kept = [np.sum(~np.any(np.abs(np.concatenate(sim.calls, axis=1)[2][r * n:(r + 1) * n][:, index]) > 100.0, axis=-1)) for r in range(B)]
    assert kept == [1500, 1497, 2, 1, 1499]  # the spins are where they were meant to be
    # n = 2500: two replicates would exceed 4000 realisations, so one per simulation
    sim = _Recording()
    bootstrap_replicates(sim, base, 2500, index, np.zeros(4), None, 0.5, np.random.default_rng(9), 2)
    assert [x.shape[1] for x in sim.calls] == [2500, 2500]


def test_the_bootstrap_replicates_add_the_measurement_noise():
    """A model without spread (b = 0): each channel's realisations are its noise alone, variance
    v = 1e-4, 4, 1e-2, 0.25, so with the model's [mean, sqrt v] the z of the mean are t with n - 1
    = 99 degrees of freedom (E z^2 = 99/97) and those of the std about standard normal (delta
    method, its scale estimated from the same 100 draws: a little wider), so over 40 replicates x
    48 cells mean(z^2) is 1.0 within 0.3 (1.06 to 1.13 over ten seeds; its sd ~ 0.03). The noise
    left out, or with its sd squared, gives stds off by many of their scales."""
    from uqdrive.inference.discrepancy.band import band_of_replicates, bootstrap_replicates

    v = np.array([1e-4, 4.0, 1e-2, 0.25])
    base = type("Base", (), dict(theta_=np.array([0.5, 0.0]), structure_=None, jacobian_=np.zeros((48, 0)),
                                 statistics_=np.stack([np.full((4, 6), 0.5), np.broadcast_to(np.sqrt(v)[:, None], (4, 6))])))()
    band = band_of_replicates(bootstrap_replicates(_Recording(), base, 100, np.arange(1, 7), v, None, 0.0, np.random.default_rng(10), 40), base, 0.05)
    assert band.mean_square_null == pytest.approx(1.0, abs=0.3)


def test_a_band_with_the_models_own_sampling_holds_it():
    """A model evaluated on m raw realisations errs by its own sampling as much as the data's n
    do by theirs: with z = (data statistics - model statistics) / the scale of both (model ratio
    n / m = 2), E z^2 = (1/n + 1/m) / (3/n) = 1 when every replicate meets the model on fresh
    germs (``model``), and 1/3 against the model's fixed, exact statistics. Over 60 replicates x
    48 independent cells each mean is within 10 % (sd ~ 3 %). Replicates drawn at model ratio 0
    and compared at ratio 2 (:meth:`Replicates.scale_at`) give the band of replicates drawn at 2."""
    from uqdrive.inference.discrepancy.band import band_of_replicates, bootstrap_replicates

    n, m, index = 200, 100, np.arange(1, 7)
    base = type("Base", (), dict(theta_=np.array([0.5, 2.0]), structure_=None, jacobian_=np.zeros((48, 0)),
                                 statistics_=np.stack([np.full((4, 6), 0.5), np.full((4, 6), 2.0)])))()
    model_sim, rng = _Recording(), np.random.default_rng(13)
    model = np.array([moment_statistics(model_sim.simulate(base.theta_, None, _Germs.draw(rng, m, 32)), index) for _ in range(60)])
    fixed = band_of_replicates(bootstrap_replicates(_Recording(), base, n, index, np.zeros(4), None, n / m, np.random.default_rng(11), 60), base, 0.05)
    replicates = bootstrap_replicates(_Recording(), base, n, index, np.zeros(4), None, n / m, np.random.default_rng(11), 60)
    fresh = band_of_replicates(replicates, base, 0.05, model=model)
    assert fixed.mean_square_null == pytest.approx(1 / 3, rel=0.1)
    assert fresh.mean_square_null == pytest.approx(1.0, rel=0.1)
    unscaled = bootstrap_replicates(_Recording(), base, n, index, np.zeros(4), None, 0.0, np.random.default_rng(11), 60)
    rescaled = band_of_replicates(unscaled, base, 0.05, model=model, ratio=n / m)
    np.testing.assert_allclose(rescaled.chi2_null, fresh.chi2_null, rtol=1e-12)
    assert band_of_replicates(unscaled, base, 0.05, model=model).mean_square_null == pytest.approx(3.0, rel=0.1)
    # a Jacobian given for the comparison's scale is the one projected out
    J = np.random.default_rng(12).standard_normal((48, 3))
    projected = band_of_replicates(replicates, base, 0.05, model=model, jacobian=J)
    assert projected.mean_square_null == pytest.approx(fresh.mean_square_null * 45 / 48, rel=0.1)


@settings(max_examples=40, deadline=None, database=None, derandomize=True)
@given(st.integers(1, 4), st.integers(2, 60), st.integers(2, 30), st.integers(0, 2**32 - 1))
def test_the_compiled_moments_are_numpys_bit_for_bit(channels, runs, times, seed):
    """The mean and std (ddof 1) over realisations equal NumPy's on a C-contiguous copy bit for bit,
    read from the copy, from a view of consecutive times and from a gathered selection alike (at
    one time alone NumPy sums the realisations pairwise, which differs in the last bit)."""
    from uqdrive.inference.discrepancy.band import mean_std

    rng = np.random.default_rng(seed)
    x = rng.normal(rng.uniform(-5, 5), rng.uniform(1e-3, 10.0), (channels, runs, times + 3))
    for xs in (x[:, :, 1:times + 1], x[:, :, ::2], x[:, :, np.arange(times) % (times + 3)]):
        copy = np.ascontiguousarray(xs)
        mean = copy.mean(axis=1, keepdims=True)
        expected = np.stack([mean[:, 0], copy.std(axis=1, ddof=1, mean=mean)])
        np.testing.assert_array_equal(mean_std(xs), expected)
        np.testing.assert_array_equal(mean_std(copy), expected)

"""StructureFit's simulations: a numerically integrated model's difference neighbours simulated in
the pass of their centre, and the statistics taken from the simulators' time-major output, give
the fit the numbers of one simulation per call and of the earlier copies, to the last bit."""

import dataclasses

import numpy as np
import pytest

from types import SimpleNamespace

from uqdrive.inference.discrepancy import selection
from uqdrive.inference.discrepancy.band import NullBand, scan_windows, statistic_scale
from uqdrive.inference.discrepancy.comparison import Compared, ModelComparison
from uqdrive.inference.discrepancy.effectset import testable as _testable
from uqdrive.inference.discrepancy.fit import THETA_BOUNDS, THETA_SCALE, SpreadCoordinates, StructureFit
from uqdrive.inference.discrepancy.fitter import CandidateFitter
from uqdrive.inference.discrepancy.ranking import gauss_newton_chi2
from uqdrive.vehicle.augmented import THETA_NAMES, AugmentedSimulator
from uqdrive.vehicle.effects import EFFECTS, Effect, ModelStructure, expand_names
from uqdrive.settings import Settings

THETA = np.array([1.0, 0.2, 1.55, 0.2, -400.0, 400.0])


@pytest.fixture(scope="module")
def sim(config):
    t = np.arange(301) * 0.01
    delta = np.deg2rad(5.0) * np.sin(2 * np.pi * t / 2.0)
    return AugmentedSimulator.drawn(Settings.from_config(config), t, delta, 25.0, 24, np.random.default_rng(11), stride=4)


class _OnePassPerCall(StructureFit):
    """The fit without simulating ahead (each call simulates what it asks for)."""

    def _simulate(self, pairs, then=()):
        return super()._simulate(pairs)


class _Counting:
    """The simulator, counting RK4 passes (calls of simulate_many) and simulated pairs."""

    def __init__(self, sim):
        self.sim, self.passes, self.pairs = sim, 0, 0

    def __getattr__(self, name):
        return getattr(self.sim, name)

    def simulate_many(self, thetas, structures, groups=None):
        self.passes += 1
        self.pairs += len(thetas)
        return self.sim.simulate_many(thetas, structures, groups)


@pytest.mark.parametrize("fit_theta", [True, False])
def test_neighbours_simulated_ahead_change_no_number_and_halve_the_passes(sim, fit_theta):
    """A Magic-Formula fit (joint, or the effect alone as in screening) to the statistics of the
    model at E = 0.6: every attribute equal to the one-pass-per-call fit's bit for bit, with
    about half its RK4 passes and no more simulated pairs than the Jacobians need plus the
    neighbours of at most one rejected step per evaluation."""
    index = np.arange(1, sim.output_time.size)
    effect = EFFECTS["tyre_saturation"]
    x = sim.simulate(THETA * [1.05, 1, 1, 1, 1, 1], effect.augment(ModelStructure(), [0.6]))
    noise = np.full(4, 1e-8)
    measured = StructureFit(sim, index, noise, 0.2).statistics(THETA, effect.augment(ModelStructure(), [0.6]))
    scale = statistic_scale(x, index) + 1e-6
    fits = {}
    for cls in (StructureFit, _OnePassPerCall):
        counted = _Counting(sim)
        f = cls(counted, index, noise, 0.2, effect=effect, fit_theta=fit_theta, max_nfev=5)
        fits[cls] = (f.fit(measured, scale, THETA, effect_start=[0.97]), counted)
    (ahead, c_ahead), (plain, c_plain) = fits[StructureFit], fits[_OnePassPerCall]
    for attr in ("theta_", "effect_values_", "statistics_", "z_", "jacobian_", "parameter_cov_"):
        assert np.array_equal(getattr(ahead, attr), getattr(plain, attr)), attr
    assert ahead.chi2_ == plain.chi2_ and ahead.nfev_ == plain.nfev_
    assert c_plain.passes >= 2 * ahead.nfev_ - 1 and c_ahead.passes <= ahead.nfev_ + 1
    p = ahead.jacobian_.shape[1]
    assert c_ahead.pairs <= c_plain.pairs + p * ahead.nfev_


@pytest.mark.parametrize("layout", ["time-major", "C"])
@pytest.mark.parametrize("spun", [0, 3])
def test_statistics_of_any_layout_equal_the_earlier_copies(sim, layout, spun):
    """[mean, std] with the output map and the noise, against the formula of the earlier code
    (x[:, keep][:, :, index], whose sums ran realisation by realisation), bit for bit."""
    rng = np.random.default_rng(4)
    K1, n = 40, 50
    x = (rng.standard_normal((K1, 4, n)) * [[1.0], [2.0], [0.02], [30.0]] + [[0.3], [0.3], [0.0], [0.3]]).transpose(1, 2, 0)
    x = x if layout == "time-major" else np.ascontiguousarray(x)
    x[2, :spun, 7] = 0.5  # beyond the spin threshold: left out
    s = ModelStructure(output_gain=(1.0, 1.1, 1.0, 1.0), output_offset=(0.0, 0.0, 0.01, 0.0))
    noise = np.array([1e-6, 2e-6, 1e-8, 1e-4])
    index = np.arange(1, K1)
    got = StructureFit(sim, index, noise, 0.2)._measured_statistics(x, s)
    keep = ~np.any(np.abs(x[2]) > 0.2, axis=-1)
    xs = x[:, keep][:, :, index]
    gain = np.asarray(s.output_gain)[:, None]
    mean = xs.mean(axis=1) * gain + np.asarray(s.output_offset)[:, None]
    std = np.sqrt((xs.std(axis=1, ddof=1) * gain) ** 2 + noise[:, None])
    assert keep.sum() == n - spun and np.array_equal(got, np.stack([mean, std]))


# -- golden values with a model whose moments are known in closed form -----------------------
class _Analytic:
    """A stand-in simulator whose realisations are linear in orthonormal germs: state s at time t
    of realisation r is A (mu_mean + mu_std g0) + B (l_f_mean + l_f_std g1) + C (wind mid + wind
    half-width g2 / sqrt 3) + D a_lat, so the sample mean and std (ddof 1) are exactly
    A mu_mean + B l_f_mean + C mid + D a_lat and sqrt((A mu_std)^2 + (B l_f_std)^2 + (C hw / sqrt 3)^2).
    ``spun``: realisations given |beta| = 1e4 (beyond the threshold 1e5 of the tests; the others stay below 1e4)."""

    channels, spin_row = ("psi", "psi_dot", "beta", "y"), 2  # the four states; beta flags lost control

    def __init__(self, n=40, T=12, spun=()):
        rng = np.random.default_rng(5)
        q, _ = np.linalg.qr(np.column_stack([np.ones(n), rng.standard_normal((n, 3))]))
        self.g = q[:, 1:].T * np.sqrt(n - 1)  # (3, n): mean 0, sample variance 1, uncorrelated
        t = np.linspace(0.1, 1.0, T)
        self.A, self.B, self.C, self.D = (np.stack([f(t) * (k + 1) for k in range(4)]) for f in (np.sin, np.cos, np.sqrt, lambda t: t**2))
        self.spun = list(spun)

    def moments(self, theta, a_lat=0.0):
        mid, hw = 0.5 * (theta[4] + theta[5]), 0.5 * (theta[5] - theta[4])
        mean = self.A * theta[0] + self.B * theta[2] + self.C * mid + self.D * a_lat
        std = np.sqrt((self.A * theta[1]) ** 2 + (self.B * theta[3]) ** 2 + (self.C * hw / np.sqrt(3)) ** 2)
        return mean, std

    def simulate_many(self, thetas, structures, groups=None):
        out = []
        for th, s in zip(thetas, structures):
            mid, hw = 0.5 * (th[4] + th[5]), 0.5 * (th[5] - th[4])
            x = (self.A[:, None] * (th[0] + th[1] * self.g[0][:, None]) + self.B[:, None] * (th[2] + th[3] * self.g[1][:, None])
                 + self.C[:, None] * (mid + hw / np.sqrt(3) * self.g[2][:, None]) + self.D[:, None] * s.lateral_acceleration)
            x[2, self.spun] = 1e6
            out.append(x)
        return out


TRUTH = np.array([0.9, 0.15, 1.5, 0.1, -300.0, 500.0])


def _measured(sim, theta, a_lat=0.0, noise=np.zeros(4)):
    mean, std = sim.moments(theta, a_lat)
    return np.stack([mean, np.sqrt(std**2 + noise[:, None])])


def test_statistics_add_the_noise_variance_and_apply_the_output_map():
    sim = _Analytic()
    noise = np.array([1e-3, 2e-3, 0.0, 0.5])
    f = StructureFit(sim, np.arange(12), noise)
    np.testing.assert_allclose(f.statistics(TRUTH, ModelStructure()), _measured(sim, TRUTH, noise=noise), rtol=1e-10)
    gain, offset = (1.0, 1.2, 1.0, 1.0), (0.0, 0.0, 0.0, 0.3)
    s = ModelStructure(output_gain=gain, output_offset=offset)
    mean, std = sim.moments(TRUTH)
    g, o = np.array(gain)[:, None], np.array(offset)[:, None]
    want = np.stack([mean * g + o, np.sqrt((std * g) ** 2 + noise[:, None])])
    np.testing.assert_allclose(f.statistics(TRUTH, s), want, rtol=1e-10)


def test_spun_model_realisations_are_left_out_as_the_datas():
    sim, clean = _Analytic(spun=[0, 3]), _Analytic()
    f = StructureFit(sim, np.arange(12), np.zeros(4), spin_threshold=1e5)
    x = clean.simulate_many([TRUTH], [ModelStructure()])[0]
    kept = np.delete(x, [0, 3], axis=1)
    np.testing.assert_allclose(f.statistics(TRUTH, ModelStructure())[0], kept.mean(axis=1), rtol=1e-12)
    np.testing.assert_allclose(f.statistics(TRUTH, ModelStructure())[1], kept.std(axis=1, ddof=1), rtol=1e-12)
    # without a threshold every realisation counts (the spun ones too)
    assert StructureFit(sim, np.arange(12), np.zeros(4)).statistics(TRUTH, ModelStructure())[1, 2].max() > 1e5


def test_fit_recovers_distributions_and_effect_and_reports_their_intervals():
    """From a start far off (wind bounds swapped: the moments are even in their order), the fit
    finds the truth (chi2 ~ 0), sorts the wind bounds, and the intervals are the Gauss-Newton
    ones: estimate -+ 1.96 sqrt(inflation x (J'J)^-1)."""
    sim = _Analytic()
    phi = 2.0  # deg of road bank: a_lat = g sin(phi)
    a_lat = EFFECTS["road_bank"].augment(ModelStructure(), [phi]).lateral_acceleration
    measured = _measured(sim, TRUTH, a_lat)
    scale = np.full_like(measured, 1e-2)
    f = StructureFit(sim, np.arange(12), np.zeros(4), effect=EFFECTS["road_bank"], max_nfev=200)
    f.fit(measured, scale, [1.2, 0.3, 1.3, 0.3, 400.0, -400.0], effect_start=[0.5])
    np.testing.assert_allclose(f.theta_, TRUTH, rtol=1e-4, atol=1e-3)
    assert f.effect_values_[0] == pytest.approx(phi, rel=1e-5)
    assert f.chi2_ < 1e-6 and f.success_ and f.nfev_ >= 1
    assert f.parameter_names == THETA_NAMES + ("phi",)
    np.testing.assert_allclose(f.z_, (f.statistics_ - measured) / scale)
    cov = np.linalg.pinv(f.jacobian_.T @ f.jacobian_)
    np.testing.assert_allclose(f.parameter_cov_, cov, rtol=1e-8)
    for inflation in (1.0, 4.0):
        est, lo, hi = f.effect_intervals(inflation)["phi"]
        half = 1.959963984540054 * np.sqrt(cov[6, 6] * inflation)
        assert (est, lo, hi) == pytest.approx((f.effect_values_[0], est - half, est + half), rel=1e-8)
    assert StructureFit(sim, np.arange(12), np.zeros(4)).fit(measured, scale, TRUTH).effect_intervals() == {}


def test_screening_holds_the_distributions_and_fits_the_effect_alone():
    sim = _Analytic()
    a_lat = EFFECTS["road_bank"].augment(ModelStructure(), [-1.5]).lateral_acceleration
    measured = _measured(sim, TRUTH, a_lat)
    f = StructureFit(sim, np.arange(12), np.zeros(4), effect=EFFECTS["road_bank"], fit_theta=False, fixed={2: 9.9})
    f.fit(measured, np.full_like(measured, 1e-2), TRUTH)
    np.testing.assert_array_equal(f.theta_, TRUTH)  # held (and ``fixed`` ignored when theta is not fitted)
    assert f.effect_values_[0] == pytest.approx(-1.5, rel=1e-6)
    assert f.parameter_names == ("phi",) and f.jacobian_.shape == (96, 1)
    est, lo, hi = f.effect_intervals()["phi"]
    assert hi - est == pytest.approx(1.959963984540054 * np.sqrt(np.linalg.pinv(f.jacobian_.T @ f.jacobian_)[0, 0]), rel=1e-8)
    lo_b, hi_b = f.parameter_bounds
    np.testing.assert_array_equal([lo_b[0], hi_b[0]], EFFECTS["road_bank"].bounds[0])


def test_known_parameters_are_held_at_their_values_and_get_no_jacobian():
    """l_f known (mean 1.5, std 0): held exactly, its columns of the Jacobian zero; the others fitted."""
    sim = _Analytic()
    measured = _measured(sim, TRUTH)
    f = StructureFit(sim, np.arange(12), np.zeros(4), fixed={2: 1.5, 3: 0.0})
    f.fit(measured, np.full_like(measured, 1e-2), [1.2, 0.3, 1.9, 0.3, -100.0, 100.0])
    assert f.theta_[2] == 1.5 and f.theta_[3] == 0.0
    assert np.all(f.jacobian_[:, [2, 3]] == 0.0) and np.all(np.any(f.jacobian_[:, [0, 1, 4, 5]] != 0.0, axis=0))
    np.testing.assert_allclose(f.theta_[[0, 4, 5]], TRUTH[[0, 4, 5]], rtol=1e-4)
    everything = StructureFit(sim, np.arange(12), np.zeros(4), fixed=dict(enumerate(TRUTH)))
    everything.fit(measured, np.full_like(measured, 1e-2), [1.2, 0.3, 1.9, 0.3, -100.0, 100.0])
    np.testing.assert_array_equal(everything.theta_, TRUTH)
    assert everything.nfev_ == 1 and everything.message_ == "nothing to fit" and everything.chi2_ < 1e-20


def test_known_theta_maps_the_configs_known_quantities(config):
    u = {**config["uncertainty"], "l_f": {"mean": 1.4, "std": 0.0}, "F_w_mean": {"low": 50.0, "high": 50.0}}
    
    assert dict(Settings.from_config({**config, "uncertainty": u}).layout.known) == {2: 1.4, 3: 0.0, 4: 50.0, 5: 50.0}
    u = {**config["uncertainty"], "mu": {"mean": 0.8, "std": 0.0}}
    assert dict(Settings.from_config({**config, "uncertainty": u}).layout.known) == {0: 0.8, 1: 0.0}


def test_gauss_newton_chi2_is_the_linear_least_squares_rest_within_the_bounds():
    """z = -J d* + r with r orthogonal to J's columns: the unbounded prediction is |r|^2 whatever
    the columns' units (a known parameter's zero column ignored); a bound that keeps the second
    parameter from its step d*_2 = 2 at 1 adds the rest of that step, |J_2|^2 (2 - 1)^2 for
    orthogonal columns; a step already at its bound (upper 0) cannot move that way."""
    rng = np.random.default_rng(3)
    q, _ = np.linalg.qr(rng.standard_normal((30, 3)))
    J = q[:, :2] * [1e-3, 5.0]  # orthogonal columns, very different units
    r = q[:, 2] * 0.7
    z = -J @ [3.0, 2.0] + r
    J0 = np.column_stack([J, np.zeros(30)])
    assert gauss_newton_chi2(z, J0) == pytest.approx(0.49, rel=1e-9)
    assert gauss_newton_chi2(z, J0, [-np.inf] * 3, [np.inf, 1.0, 0.0]) == pytest.approx(0.49 + 25.0 * 1.0, rel=1e-9)
    assert gauss_newton_chi2(z, J0, [-np.inf] * 3, [np.inf, 0.0, 0.0]) == pytest.approx(0.49 + 25.0 * 4.0, rel=1e-9)
    assert gauss_newton_chi2(z, np.zeros((30, 2))) == pytest.approx(z @ z)


class _Gusty(_Analytic):
    """The stand-in with gusts: a fourth germ g3 whose spread G = C (1.5 - t) x gust_scale adds
    the variance (G gust_scale)^2, close to the mean wind's C hw / sqrt 3 but not equal to it."""

    def __init__(self, n=40, T=12):
        super().__init__(n, T)
        q, _ = np.linalg.qr(np.column_stack([np.ones(n), np.random.default_rng(6).standard_normal((n, 4))]))
        self.g = q[:, 1:].T * np.sqrt(n - 1)  # (4, n): mean 0, sample variance 1, uncorrelated
        self.G = self.C * (1.5 - np.linspace(0.1, 1.0, T))

    def moments(self, theta, a_lat=0.0, gust=1.0):
        mean, std = super().moments(theta, a_lat)
        return mean, np.sqrt(std**2 + (self.G * gust) ** 2)

    def simulate_many(self, thetas, structures, groups=None):
        out = super().simulate_many(thetas, structures, groups)
        return [x + self.G[:, None, :] * s.gust_scale * self.g[3][None, :, None] for x, s in zip(out, structures)]


def test_forward_selection_names_an_effect_the_distributions_absorbed(config):
    """A road bank (2 deg) and gusts 6 times the configured ones, on exact moments. The baseline
    fit absorbs the bank into mu's mean (1.98 for 0.9) and the gusts into l_f's spread (at its
    bound 1): held there, the bank lowers chi2 by 2 % and the gusts by 10 %, so with one joint
    fit per step the gusts went first, their joint fit kept the absorbed bank and closed less
    than a quarter of the gap, and nothing was named. Ranked by the Gauss-Newton prediction of
    the joint fit (the distributions free), the bank comes first (its prediction 1731 is what the
    joint fit reaches), then the gusts; the truth is recovered exactly (chi2 ~ 0)."""
    sim = _Gusty()
    a_lat = EFFECTS["road_bank"].augment(ModelStructure(), [2.0]).lateral_acceleration
    mean, std = sim.moments(TRUTH, a_lat, gust=6.0)
    measured = np.stack([mean, std])
    band = NullBand.from_replicates(np.random.default_rng(0).standard_normal((200, 2, 4, 12)), scan_windows(12), 0.01)
    settings = Settings.from_config(config)
    candidates = _testable(expand_names(["road_bank", "wind_gust", "sensor_scale", "sensor_bias"]), sim.channels)[0]
    # z in units of a unit-normal null band; every model's own band is that band (the stand-in has no bootstrap)
    data = Compared(sim, None, np.arange(12), np.zeros(4), None, 40, np.zeros(50), 0.01, measured, np.full_like(measured, 1e-2), 24, 24)
    comparison = ModelComparison(band, data.scale, bands=SimpleNamespace(null=lambda fit, key=0: band))
    start = list(settings.layout.start)
    fitter = CandidateFitter(data, settings.layout.known, start, settings.vehicle.E, top=1)
    base = StructureFit(sim, data.index, data.noise).fit(measured, data.scale, start)
    fw = selection.forward_selection(comparison, fitter, candidates, 2, base, band, {}, lambda *a: None)
    final = fw.final
    bank, gust = fw.screening["road_bank"], fw.screening["wind_gust"]
    assert bank["held"] > gust["held"] and bank["chi2"] < gust["chi2"]  # held: the gusts first; predicted jointly: the bank
    assert bank["chi2"] == pytest.approx(fw.fits["road_bank"].chi2_, rel=1e-3)  # the prediction is what the joint fit reaches
    assert [s.name for s in fw.steps] == ["road_bank", "wind_gust"]
    # exact moments: only the joint fit's convergence (60 evaluations, gust within 1e-4) limits the estimates;
    # the spreads of mu and l_f are not checked, the gusts' variance and theirs trade on these 12 times
    np.testing.assert_allclose(final.effect_values_, [2.0, 6.0], rtol=1e-3)
    np.testing.assert_allclose(final.theta_[[0, 2, 4, 5]], TRUTH[[0, 2, 4, 5]], rtol=1e-3)
    assert final.chi2_ < 1e-3


def test_the_cache_holds_64_simulations_keyed_by_their_dynamic_part():
    """The cache (at most 64 simulations): 64 distinct thetas are simulated once each and all stay
    cached; a 65th empties it first and stays cached itself, so asking for it again costs
    nothing and the first theta costs a pass again. A structure that differs only in its output
    map reuses the simulation and applies its own gain."""
    counted = _Counting(_Analytic())
    f = StructureFit(counted, np.arange(12), np.zeros(4))
    thetas = [TRUTH + [1e-3 * k, 0, 0, 0, 0, 0] for k in range(65)]
    for th in thetas[:64]:
        f.statistics(th, ModelStructure())
    assert counted.passes == 64
    first = f.statistics(thetas[0], ModelStructure())
    gained = f.statistics(thetas[0], ModelStructure(output_gain=(1.0, 2.0, 1.0, 1.0)))
    assert counted.passes == 64  # the 64 are all cached; the gain needs no simulation
    np.testing.assert_array_equal(gained[:, 1], 2.0 * first[:, 1])
    f.statistics(thetas[64], ModelStructure())
    f.statistics(thetas[64], ModelStructure())
    assert counted.passes == 65  # the 65th is simulated once and kept
    f.statistics(thetas[0], ModelStructure())
    assert counted.passes == 66  # the 65th emptied the cache: the first simulated again


def test_two_unspun_realisations_are_enough_one_is_not():
    """As the data's rule: the statistics of the kept realisations when at least 2 are left (here
    exactly 2: their mean and std, ddof 1), of all of them (the spun ones too) when only 1 is."""
    clean = _Analytic().simulate_many([TRUTH], [ModelStructure()])[0]
    two = StructureFit(_Analytic(spun=range(38)), np.arange(12), np.zeros(4), spin_threshold=1e5).statistics(TRUTH, ModelStructure())
    kept = clean[:, 38:]
    np.testing.assert_allclose(two[0], kept.mean(axis=1), rtol=1e-12)
    np.testing.assert_allclose(two[1], kept.std(axis=1, ddof=1), rtol=1e-12)
    one = StructureFit(_Analytic(spun=range(39)), np.arange(12), np.zeros(4), spin_threshold=1e5).statistics(TRUTH, ModelStructure())
    assert one[1, 2].min() > 1e5  # beta's spread includes the 39 spun realisations at 1e6


def test_statistics_equal_the_simulators_own_measured_channels(config):
    """The fit simulates the structure without its output map (cached by that dynamic part) and
    applies the map itself: the mean and std (ddof 1) of the simulator's own output with the map
    (gains and offsets of the states and of a_y) plus the noise variance, to rounding (rtol 1e-12:
    g mean(x) + o against mean(g x + o))."""
    t = np.arange(101) * 0.01
    delta = np.deg2rad(5.0) * np.sin(2 * np.pi * t / 2.0)
    sim = AugmentedSimulator.drawn(Settings.from_config(config), t, delta, 25.0, 16, np.random.default_rng(12), stride=4, channels=("psi_dot", "beta", "a_y"))
    s = ModelStructure(output_gain=(1.0, 1.1, 0.9, 1.0), output_offset=(0.0, 0.01, 0.002, 0.0), a_y_gain=1.05, a_y_offset=0.2)
    index = np.arange(1, sim.output_time.size)
    noise = np.array([1e-6, 1e-8, 1e-3])
    got = StructureFit(sim, index, noise).statistics(THETA, s)
    xs = sim.simulate(THETA, s)[:, :, index]
    want = np.stack([xs.mean(axis=1), np.sqrt(xs.var(axis=1, ddof=1) + noise[:, None])])
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-15)


def test_a_budget_of_one_evaluation_returns_the_start():
    """trf with max_nfev = 1 stops after the residuals at its start: the estimate is theta0 itself
    (an interior start unchanged), a start outside the bounds clipped into them (mu mean 5 -> 3
    within 1e-8 of the range; a negative std -> 0, searched as its square, which trf moves 1e-10
    into its range: a std of 1e-5 at most), the wind bounds sorted. So is an effect's
    start outside its bounds (a road bank bounded to [-12, 3] deg: lo + hi < 0, so a clip at
    lo + 1e-9 (hi + lo) or hi - 1e-9 (hi + lo) would leave it outside and trf would refuse it)."""
    sim = _Analytic()
    measured = _measured(sim, TRUTH)
    start = np.array([1.2, 0.3, 1.3, 0.25, -100.0, 200.0])
    f = StructureFit(sim, np.arange(12), np.zeros(4), max_nfev=1).fit(measured, np.full_like(measured, 1e-2), start)
    np.testing.assert_allclose(f.theta_, start, rtol=1e-12)
    assert f.nfev_ == 1 and not f.success_
    f.fit(measured, np.full_like(measured, 1e-2), [5.0, -0.5, 1.3, 0.25, 200.0, -100.0])
    assert 3.0 - 1e-8 < f.theta_[0] < 3.0 and 0.0 < f.theta_[1] <= 1e-5 * (1 + 1e-12)
    np.testing.assert_allclose(f.theta_[2:], start[2:], rtol=1e-12)
    bank = dataclasses.replace(EFFECTS["road_bank"], bounds=((-12.0, 3.0),))
    g = StructureFit(sim, np.arange(12), np.zeros(4), effect=bank, max_nfev=1)
    for effect_start, inside in (([5.0], (3.0 - 1.5e-7, 3.0)), ([-20.0], (-12.0, -12.0 + 1.5e-7))):
        g.fit(measured, np.full_like(measured, 1e-2), start, effect_start=effect_start)
        assert inside[0] < g.effect_values_[0] < inside[1]  # within 1e-8 of the range 15
        np.testing.assert_allclose(g.theta_, start, rtol=1e-12)


def test_statistics_many_equal_statistics_pair_by_pair():
    """Three (theta, structure) pairs in batches of 2 (2 + 1): each equal to :meth:`statistics` of
    its pair alone (the stand-in's realisations do not depend on the batch: to rounding)."""
    sim = _Analytic()
    f = StructureFit(sim, np.arange(12), np.full(4, 1e-3))
    thetas = [TRUTH, TRUTH * [1.1, 1, 1, 1, 1, 1], TRUTH * [1, 1, 0.9, 2, 1, 1]]
    structures = [ModelStructure(), EFFECTS["road_bank"].augment(ModelStructure(), [2.0]), ModelStructure(output_gain=(1.0, 1.2, 1.0, 1.0))]
    got = f.statistics_many(thetas, structures, batch=2)
    assert got.shape == (3, 2, 4, 12)
    for g, th, s in zip(got, thetas, structures):
        np.testing.assert_allclose(g, f.statistics(th, s), rtol=1e-12)


def test_nothing_to_fit_gives_the_start_and_empty_parameter_arrays():
    """theta held (fit_theta False) and no effect: no parameter, so the estimate is the start, the
    Jacobian has no columns, the covariance is 0 x 0 and there are no intervals."""
    sim = _Analytic()
    measured = _measured(sim, TRUTH)
    f = StructureFit(sim, np.arange(12), np.zeros(4), fit_theta=False).fit(measured, np.full_like(measured, 1e-2), TRUTH * 1.1)
    np.testing.assert_array_equal(f.theta_, TRUTH * 1.1)
    assert f.jacobian_.shape == (96, 0) and f.parameter_cov_.shape == (0, 0) and f.effect_intervals() == {}
    assert f.parameter_names == () and f.message_ == "nothing to fit" and f.nfev_ == 1
    np.testing.assert_allclose(f.z_, (_measured(sim, TRUTH * 1.1) - measured) / 1e-2, rtol=1e-10)


class _BankAndGusts(Effect):
    """A two-parameter effect for the stand-in: lateral acceleration (m/s^2) and gust scale."""

    def apply(self, s, v):
        return dataclasses.replace(s, lateral_acceleration=float(v[0]), gust_scale=float(v[1]))


def test_intervals_of_a_two_parameter_effect_take_their_own_variances():
    """Each parameter's interval is estimate -+ 1.96 sqrt(inflation x its own diagonal entry of
    (J'J)^-1): entries 6 and 7 after the six distribution parameters, 0 and 1 when theta is held."""
    sim = _Gusty()
    effect = _BankAndGusts("bank_and_gusts", ("a", "g"), ("m/s^2", "-"), ((-5.0, 5.0), (0.0, 20.0)), (0.5, 2.0), "", "")
    mean, std = sim.moments(TRUTH, 0.3, gust=3.0)
    measured = np.stack([mean, std])
    for fit_theta, offset in ((True, 6), (False, 0)):
        f = StructureFit(sim, np.arange(12), np.zeros(4), effect=effect, fit_theta=fit_theta, max_nfev=20)
        f.fit(measured, np.full_like(measured, 1e-2), TRUTH)
        cov = np.linalg.pinv(f.jacobian_.T @ f.jacobian_)
        assert cov.shape == (offset + 2, offset + 2)
        for i, name in enumerate(("a", "g")):
            est, lo, hi = f.effect_intervals(2.0)[name]
            half = 1.959963984540054 * np.sqrt(2.0 * cov[offset + i, offset + i])
            assert (est, lo, hi) == pytest.approx((f.effect_values_[i], est - half, est + half), rel=1e-8)


class _CountingSimulate:
    """The simulator, counting its single simulations (a linear model's only kind)."""

    def __init__(self, sim):
        self.sim, self.calls = sim, 0

    def __getattr__(self, name):
        return getattr(self.sim, name)

    def simulate(self, theta, structure=ModelStructure(), germs=None):
        self.calls += 1
        return self.sim.simulate(theta, structure, germs)

    def simulate_many(self, thetas, structures, groups=None):
        return [self.simulate(th, s) for th, s in zip(thetas, structures)]


def test_fits_sharing_a_memo_simulate_a_linear_model_once_with_the_same_numbers(sim):
    """Two fits of a road bank on one simulator with a shared memo: the first has every number of
    a fit without one, bit for bit; the second, from the same start, simulates nothing (all its
    points are the first's); held screening fits of output-only effects at one estimate simulate
    the model there once between them, with the numbers of a fit without the memo. The memo
    keeps its newest ``size`` entries, per simulator."""
    from uqdrive.inference.discrepancy.fitter import SimulationMemo

    index = np.arange(1, sim.output_time.size)
    structure = EFFECTS["road_bank"].augment(ModelStructure(), [1.5])
    measured = StructureFit(sim, index, np.full(4, 1e-6)).statistics(THETA * [1.1, 1, 1, 1, 1, 1], structure)
    scale = np.full_like(measured, 1e-2)
    start = THETA * [0.9, 1.2, 1.05, 0.8, 1, 1]

    def fit(simulator, memo, effect="road_bank", **kwargs):
        f = StructureFit(simulator, index, np.full(4, 1e-6), effect=EFFECTS[effect], max_nfev=8, memo=memo, **kwargs)
        return f.fit(measured, scale, start if kwargs.get("fit_theta", True) else alone.theta_)

    alone = fit(sim, None)
    memo, counted = SimulationMemo(size=64), _CountingSimulate(sim)
    first = fit(counted, memo)
    for name in ("theta_", "effect_values_", "statistics_", "z_", "jacobian_", "parameter_cov_"):
        np.testing.assert_array_equal(getattr(first, name), getattr(alone, name))
    assert first.chi2_ == alone.chi2_ and counted.calls > 8
    calls = counted.calls
    second = fit(counted, memo)
    assert counted.calls == calls and second.chi2_ == first.chi2_
    fit(counted, memo, effect="sensor_bias_psi_dot", fit_theta=False)
    assert counted.calls == calls + 1  # the baseline at alone's estimate, once
    other = fit(counted, memo, effect="sensor_scale_psi_dot", fit_theta=False)
    assert counted.calls == calls + 1 and other.chi2_ == fit(sim, None, effect="sensor_scale_psi_dot", fit_theta=False).chi2_

    small, key = SimulationMemo(size=2), (b"k", ModelStructure())
    for k, x in enumerate("abc"):
        small.put(sim, (str(k).encode(), ModelStructure()), x)
    assert small.get(sim, (b"0", ModelStructure())) is None and small.get(sim, (b"2", ModelStructure())) == "c"
    small.put(sim, key, "x")
    assert small.get(counted, key) is None and small.get(sim, key) == "x"  # another simulator's entry is not this one's


def test_linear_fit_along_a_speed_profile_simulates_ahead_with_the_same_numbers(config):
    """Along a speed profile a linear model is integrated by RK4, so a point's difference
    neighbours are simulated in the pass of the point (with the memo of a discover): every
    attribute equals the one-pass-per-call fit's bit for bit, in about half its passes."""
    from uqdrive.inference.discrepancy.fitter import SimulationMemo

    t = np.arange(201) * 0.01
    speed = np.interp(t, [0.0, 0.5, 1.5, 2.0], [25.0, 25.0, 18.0, 18.0])
    sim = AugmentedSimulator.drawn(Settings.from_config(config), t, np.deg2rad(3.0) * np.sin(2 * np.pi * t / 1.5), 21.5, 16,
                                   np.random.default_rng(3), stride=4, channels=("psi_dot", "a_y"), speed=speed)
    index, noise, effect = np.arange(1, sim.output_time.size), np.full(2, 1e-8), EFFECTS["road_bank"]
    measured = StructureFit(sim, index, noise).statistics(THETA * [1.05, 1, 1, 1, 1, 1], effect.augment(ModelStructure(), [1.5]))
    scale = np.abs(measured) * 0.05 + 1e-4
    fits = {}
    for cls in (StructureFit, _OnePassPerCall):
        counted = _Counting(sim)
        f = cls(counted, index, noise, effect=effect, max_nfev=5, memo=SimulationMemo())
        fits[cls] = (f.fit(measured, scale, THETA, effect_start=[0.5]), counted)
    (ahead, c_ahead), (plain, c_plain) = fits[StructureFit], fits[_OnePassPerCall]
    for attr in ("theta_", "effect_values_", "statistics_", "z_", "jacobian_", "parameter_cov_"):
        assert np.array_equal(getattr(ahead, attr), getattr(plain, attr)), attr
    assert ahead.chi2_ == plain.chi2_ and ahead.nfev_ == plain.nfev_
    assert c_plain.passes >= 2 * ahead.nfev_ - 1 and c_ahead.passes <= ahead.nfev_ + 1


def test_a_jacobians_chassis_pairs_on_two_steering_inputs_are_integrated_one_pass_per_input(config):
    """A Jacobian's step in an actuator's lag puts a chassis model on two steering inputs: each
    input's pairs share one RK4 pass, every pair with the numbers of a call of its own (bit for
    bit), in two passes instead of one per pair."""
    cfg = {**config, "vehicle": {**config["vehicle"], "cg_height": 0.55, "track_width": 1.6}}
    t = np.arange(101) * 0.01
    sim = AugmentedSimulator.drawn(Settings.from_config(cfg), t, np.deg2rad(3.0) * np.sin(2 * np.pi * t), 20.0, 12,
                                   np.random.default_rng(2), channels=("psi_dot", "a_y"))
    base = EFFECTS["roll_steer"].augment(EFFECTS["tyre_saturation"].augment(ModelStructure(), [0.97]), [0.3, 2.0, 0.6])
    lagged = [EFFECTS["actuator_lag"].augment(base, [lag]) for lag in (0.05, 0.05, 0.05, 0.0501)]
    thetas = [np.array([1.0, 0.05, 1.5, 0.02, -100.0, 100.0]) + 1e-3 * i for i in range(4)]
    alone = [sim.simulate(th, s) for th, s in zip(thetas, lagged)]
    passes = []
    one_pass = sim._one_pass
    sim._one_pass = lambda th, st, *a, **k: passes.append(len(th)) or one_pass(th, st, *a, **k)
    got = sim.simulate_many(thetas, lagged, groups=[3, 1])
    assert all(np.array_equal(a, b) for a, b in zip(got, alone))
    assert passes == [3]  # the lone pair on the second input: a call of its own


def test_spread_coordinates_are_the_squares_and_map_back_with_their_derivative():
    """A std's coordinate is its square, the wind's bounds their centre and squared width; back
    to theta to rounding (the bounds in order whatever their order), the held ones untouched,
    and d u / d theta equal to central differences (the forward map is a polynomial of degree 2:
    central differences are exact to rounding, 1e-7 relative at steps of 1e-4)."""
    x = np.array([0.9, 0.15, 1.5, 0.1, -300.0, 500.0, 2.0])
    c = SpreadCoordinates()
    u = c.forward(x)
    np.testing.assert_allclose(u, [0.9, 0.0225, 1.5, 0.01, 100.0, 640000.0, 2.0], rtol=1e-15)
    np.testing.assert_allclose(c.inverse(u), x, rtol=1e-14)
    np.testing.assert_allclose(c.inverse(c.forward(x[[0, 1, 2, 3, 5, 4, 6]])), x, rtol=1e-14)  # swapped bounds come back sorted
    steps = 1e-4 * np.maximum(np.abs(x), 1.0)
    numeric = np.column_stack([(c.forward(x + h * e) - c.forward(x - h * e)) / (2 * h) for h, e in zip(steps, np.eye(x.size))])
    np.testing.assert_allclose(c.derivative(u), numeric, rtol=1e-7, atol=1e-9)
    held = SpreadCoordinates({3: 0.0, 4: 50.0, 5: 50.0})  # a known l_f and mean wind: only mu's std squared
    np.testing.assert_array_equal(held.forward(x), [0.9, 0.0225, 1.5, 0.1, -300.0, 500.0, 2.0])
    lo, hi = (np.array(b, float) for b in zip(*THETA_BOUNDS))
    box = c.box(lo, hi, np.array(THETA_SCALE))
    np.testing.assert_array_equal(box[0], [0.1, 0.0, 0.3, 0.0, -3000.0, 0.0])
    np.testing.assert_array_equal(box[1], [3.0, 1.0, 2.5, 1.0, 3000.0, 6000.0**2])
    np.testing.assert_allclose(box[2], [1.0, 0.04, 1.5, 0.04, 400.0, 160000.0], rtol=1e-15)
    np.testing.assert_array_equal(held.box(lo, hi, np.array(THETA_SCALE))[1], [3.0, 1.0, 2.5, 1.0, 3000.0, 3000.0])


def test_a_spread_the_data_do_not_want_is_fitted_to_the_optimum_not_crept_towards_zero():
    """The data's std 3 % below what the model gives at zero l_f std and zero wind width (noise
    variance 0.01 on every channel): those spreads want to shrink, and their Jacobian columns
    vanish with them in theta. A fit not converged within THETA_EVALUATIONS goes on in the
    squares and converges, from three starts, to one optimum (chi2 equal to 1e-8: trf's ftol
    and xtol are 1e-8) within 80 of its 200 evaluations, the means at the truth; theta alone
    spends the 200 far from it (at least 100 times its chi2). A fit that converges within
    THETA_EVALUATIONS (from the fourth start) keeps its numbers bit for bit."""
    sim = _Analytic()
    theta = TRUTH.copy()
    theta[3], theta[4:6] = 0.0, 100.0
    noise = np.full(4, 0.01)
    measured = _measured(sim, theta, noise=noise)
    measured[1] *= 0.97
    scale = np.full_like(measured, 1e-2)
    starts = ([1.2, 0.3, 1.3, 0.3, -100.0, 200.0], [1.2, 0.3, 1.3, 0.3, 95.0, 105.0], [0.8, 0.2, 1.6, 0.2, 105.0, 95.0],
              [0.95, 0.1, 1.45, 0.05, 98.0, 102.0])

    def fits(squares):
        StructureFit.spread_as_variance = squares
        try:
            return [StructureFit(sim, np.arange(12), noise, max_nfev=200).fit(measured, scale, start) for start in starts]
        finally:
            StructureFit.spread_as_variance = True

    new, old = fits(True), fits(False)
    assert all(f.success_ and StructureFit.THETA_EVALUATIONS < f.nfev_ <= 80 for f in new[:3])
    np.testing.assert_allclose([f.chi2_ for f in new[:3]], new[0].chi2_, rtol=1e-8)
    np.testing.assert_allclose(new[0].theta_[[0, 2, 4, 5]], theta[[0, 2, 4, 5]], rtol=1e-6)
    assert new[0].theta_[3] < 1e-3
    assert all(not f.success_ and f.chi2_ > 100.0 * new[0].chi2_ for f in old[:3])
    assert old[3].success_ and old[3].nfev_ <= StructureFit.THETA_EVALUATIONS
    np.testing.assert_array_equal(new[3].theta_, old[3].theta_)
    np.testing.assert_array_equal(new[3].jacobian_, old[3].jacobian_)

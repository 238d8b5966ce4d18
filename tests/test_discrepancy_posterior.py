"""The emcee posterior of an augmented model (uqdrive.inference.discrepancy.posterior): its
quadratic surrogate, its likelihood times, and on a small hidden-effect ensemble whose truth is
known (made by other code, uqdrive.studies.hidden_effects): the 95 % intervals hold the truth,
and a wrong fixed vehicle constant moves them off it."""

import copy

import numpy as np
import pytest
import xarray as xr

from uqdrive.inference.discrepancy.band import moment_statistics, statistic_scale
from uqdrive.inference.discrepancy.fit import StructureFit
from uqdrive.inference.discrepancy.posterior import AugmentedPosterior, fit_quadratic, likelihood_times, quadratic_features, sample_vectorised
from uqdrive.numerics.threads import single_blas_thread
from uqdrive.studies.discrepancy import benchmark_dataset, benchmark_rows, case_outcome, thesis_posterior_rows
from uqdrive.studies.hidden_effects import HiddenEffectCase, generate
from uqdrive.vehicle.augmented import AugmentedSimulator
from uqdrive.vehicle.effects import EFFECTS
from uqdrive.vehicle.noise import estimate_noise_variance
from uqdrive.vehicle.single_track import STATES
from uqdrive.settings import Settings

TRUTH = {"mu_mean": 1.0, "mu_std": 0.2, "phi": 2.0}
SAMPLER = dict(ensembles=2, walkers=16, burn_in=100, max_steps=600, check_every=200, validate=24)
SAMPLER_TOLERANCE = 0.5  # AugmentedPosterior's default


def test_quadratic_surrogate_reproduces_a_quadratic_exactly():
    rng = np.random.default_rng(0)
    u = rng.standard_normal((40, 3))
    coef = rng.standard_normal((quadratic_features(u[:1]).shape[1], 5))
    assert quadratic_features(u[:1]).shape == (1, 1 + 3 + 6)
    assert np.allclose(fit_quadratic(u, quadratic_features(u) @ coef), coef)


def test_walkers_start_inside_the_prior_and_apart_when_the_fit_sits_on_a_bound():
    """A fit whose spread went to 0 (or a parameter to its limit) puts the centre on the open
    prior's bound: every walker must still start strictly inside and no two alike (equal walkers
    give emcee's DE snooker move a division by zero: NaN parameters, a failed run). Wide Laplace
    factors (10x the prior) leave most first draws outside."""
    post = AugmentedPosterior(ensembles=3, walkers=20)
    lo, hi = np.array([0.1, 0.0, 1.0, 0.0, -600.0, -600.0, -2.0]), np.array([2.0, 1.0, 2.0, 1.0, 600.0, 600.0, 2.0])
    post._lo, post._hi = lo, hi
    post._centre = np.array([0.9, 0.0, 1.5, 0.2, -300.0, 300.0, -2.0])  # mu std and E on their bounds
    post._factor_L = np.diag(10.0 * (hi - lo))
    for x in post._starts(np.random.default_rng(0), lo.size):
        assert x.shape == (20, 7) and post._inside(x).all()
        gaps = np.abs(x[:, None, :] - x[None, :, :]).sum(axis=-1) + np.eye(20)
        assert gaps.min() > 0


@pytest.mark.parametrize("K, n, most", [(150, 1000, 30), (150, 150, 9), (5, 1000, 5), (40, 20, 1)])
def test_likelihood_times_keep_the_covariance_estimable(K, n, most):
    sel = likelihood_times(K, n, 30)
    assert sel.size == most and sel[-1] == K - 1 and np.all(np.diff(sel) > 0) and 8 * sel.size <= max(8, (n - 2) // 2)


@pytest.fixture(scope="module")
def small(config):
    """A coarse grid (20 ms, 6 s) keeps the hidden-effect reality and the model cheap."""
    c = copy.deepcopy(config)
    c["time"].update(t_end=6.0, dt=0.02, step=0.01)
    c["wind"]["kle_quadrature"] = 120
    return c


@pytest.fixture(scope="module")
def bank(small):
    """A 2 deg road bank on a step steer, 200 realisations, LST reality with the config's
    distributions: truth mu ~ N(1.0, 0.2), phi = 2 deg."""
    return generate(small, HiddenEffectCase("bank", "road_bank", 2.0, "step", {"amplitude_deg": 2.0}, samples=200, seed=5))


def _posterior(model_config, ds: xr.Dataset, stride: int = 10, M: int = 300, seed: int = 3, channels=STATES, **sampler):
    """Joint StructureFit of road_bank on M CRN realisations of the measured ``channels``, then its posterior."""
    fit, x = _joint_fit(model_config, ds, stride, M, seed, channels)
    with single_blas_thread():
        return AugmentedPosterior(**{**SAMPLER, **sampler}).fit(fit, x, np.random.default_rng(4))


def _joint_fit(model_config, ds: xr.Dataset, stride: int = 10, M: int = 300, seed: int = 3, channels=STATES):
    """Joint StructureFit of road_bank on M CRN realisations of the measured ``channels``, and those channels (C, n, K + 1)."""
    x = np.stack([ds[s].values for s in channels])
    noise = np.array([estimate_noise_variance(x[i], order=4) for i in range(len(channels))])
    K = (x.shape[-1] - 1) // stride
    x = x[:, :, : K * stride + 1 : stride]
    index = np.arange(1, K + 1)
    sim = AugmentedSimulator.drawn(Settings.from_config(model_config), ds["time"].values, ds["delta"].values, ds.attrs["v_c"], M, np.random.default_rng(seed), stride=stride,
                                   channels=channels)
    u = model_config["uncertainty"]
    theta0 = [u["mu"]["mean"], u["mu"]["std"], u["l_f"]["mean"], u["l_f"]["std"], u["F_w_mean"]["low"], u["F_w_mean"]["high"]]
    with single_blas_thread():
        fit = StructureFit(sim, index, noise, 0.2 if "beta" in channels else None, effect=EFFECTS["road_bank"])
        fit.fit(moment_statistics(x, index), statistic_scale(x, index, model_ratio=x.shape[1] / M), theta0)
    return fit, x


def _interval(post, name):
    i = post.names_.index(name)
    return post.low_[i], post.high_[i]


def test_posterior_covers_the_truth_and_a_wrong_constant_moves_it_off(small, bank):
    """The right model: mu's mean and std and the bank angle inside their 95 % intervals, the
    surrogate validated against the full model, R-hat near 1. The same data with the front
    tyres' stiffness factor 15 % low in the model: c_f = F_z B_f C mu, so mu's mean must rise to
    compensate, and its interval (narrow: the data do pin it) leaves 1.0 behind."""
    post = _posterior(small, bank)
    for name, truth in TRUTH.items():
        lo, hi = _interval(post, name)
        assert lo <= truth <= hi, (name, lo, hi)
    assert post.validation_["passed"] and np.all(post.r_hat_ < 1.1)
    assert post.validation_["shift"] <= SAMPLER_TOLERANCE and set(post.validation_["shifts"]) == set(post.names_)
    summary = post.summary()
    assert summary["mu_mean"][1] <= 1.0 <= summary["mu_mean"][2] and {"r_hat", "tau", "surrogate", "likelihood"} <= set(summary)
    wrong = copy.deepcopy(small)
    wrong["vehicle"]["c_Sf"] *= 0.85
    lo, hi = _interval(_posterior(wrong, bank), "mu_mean")
    assert lo > 1.05, (lo, hi)


@pytest.mark.filterwarnings("ignore:os.fork\\(\\) was called:RuntimeWarning")  # JAX of another test in this process
def test_the_full_model_evaluations_on_workers_are_those_of_one_process(small, bank, tmp_path):
    """The design's and validation's evaluations in batches on two forked workers (batches of
    another size than in one process: 21 points in 4 batches of 6, not 3 of 8) give the
    statistics of one process bit for bit, in the points' order, computed by the workers."""
    import os

    fit, x = _joint_fit(small, bank, M=100)
    centre = np.concatenate([fit.theta_, fit.effect_values_])
    points = centre * (1.0 + 0.02 * np.random.default_rng(0).standard_normal((21, centre.size)))
    sel = np.arange(0, fit.index.size, 3)
    one = AugmentedPosterior(batch=8)._statistics(fit, points, sel)
    batches, simulate = tmp_path / "batches", fit.statistics_many

    def statistics_many(thetas, structures, batch):
        with open(batches, "a") as fh:  # a worker's changes stay there: the file tells who ran what
            fh.write(f"{os.getpid()} {len(thetas)}\n")
        return simulate(thetas, structures, batch)

    fit.statistics_many = statistics_many
    two = AugmentedPosterior(batch=8, jobs=2)._statistics(fit, points, sel)
    assert one.shape == (21, 2 * len(STATES) * sel.size) and np.all(np.isfinite(one))
    assert np.array_equal(two, one)
    assert not np.array_equal(one[0], one[1])  # each row is its own point's: an order mixed up would show
    ran = [line.split() for line in batches.read_text().splitlines()]
    assert sorted(int(size) for _, size in ran) == [3, 6, 6, 6] and str(os.getpid()) not in {pid for pid, _ in ran}


@pytest.mark.filterwarnings("ignore:os.fork\\(\\) was called:RuntimeWarning")  # JAX of another test in this process
def test_the_emcee_ensembles_on_workers_are_those_of_one_process(tmp_path):
    """Three ensembles on a Gaussian, on two forked workers: the chains of one process bit for
    bit (each ensemble's seed drawn in order before any runs), each ensemble its own, the
    generator left in the same state, the ensembles sampled by the workers."""
    import os

    calls = tmp_path / "calls"

    def log_prob(X):
        with open(calls, "a") as fh:
            fh.write(f"{os.getpid()}\n")
        return -0.5 * np.sum(X**2, axis=1)

    starts = [np.random.default_rng(k).standard_normal((16, 2)) for k in range(3)]
    one_rng, two_rng = np.random.default_rng(1), np.random.default_rng(1)
    one = sample_vectorised(log_prob, starts, one_rng, 400, 200)
    calls.unlink()
    two = sample_vectorised(log_prob, starts, two_rng, 400, 200, jobs=2)
    for a, b in zip(one, two, strict=True):
        assert a.keys() == b.keys() and all(np.array_equal(a[k], b[k]) for k in ("chain", "log_prob", "tau"))
        assert (a["burn"], a["thin"], a["acceptance"]) == (b["burn"], b["thin"], b["acceptance"])
    assert not np.array_equal(one[1]["chain"][-1], one[2]["chain"][-1])
    assert one_rng.integers(2**31) == two_rng.integers(2**31)
    assert str(os.getpid()) not in set(calls.read_text().split())


def test_a_surrogate_that_fails_its_check_gets_a_second_design(small, bank):
    """The same fit with a tolerance no first-order shift can meet: the check fails, the design is
    rebuilt around the first round's posterior (its validation draws kept) and emcee rerun; the
    verdict says the surrogate failed."""
    post = _posterior(small, bank, tolerance=1e-6, rounds=2)
    v = post.validation_
    assert not v["passed"] and v["rounds"] == 2 and len(v["history"]) == 2 and v["shift"] > 1e-6
    assert v["design_points"] > v["history"][0]["design_points"] - 1 and post.summary()["surrogate"]["passed"] is False


def test_posterior_on_an_imu_file_covers_the_truth(small):
    """The bank case recorded by an IMU only (psi_dot, a_y; 200 runs): the posterior runs on those
    two channels (likelihood over 2 x 2 statistics per time) and its mu mean and std and the bank
    angle hold the truth. The model compared on all four states would not even have the data's
    channels (a_y), and without a_y the bank is nearly invisible in psi_dot alone."""
    imu = generate(small, HiddenEffectCase("bank", "road_bank", 2.0, "step", {"amplitude_deg": 2.0}, samples=200, seed=5), channels=("psi_dot", "a_y"))
    post = _posterior(small, imu, channels=("psi_dot", "a_y"))
    for name, truth in TRUTH.items():
        lo, hi = _interval(post, name)
        assert lo <= truth <= hi, (name, lo, hi)
    assert post.validation_["passed"] and np.all(post.r_hat_ < 1.1)


def test_ci_config_keeps_the_posterior_off():
    from pathlib import Path

    from uqdrive.config import load_config

    root = Path(__file__).resolve().parents[1]
    assert load_config(root / "config" / "test.yaml")["discrepancy"]["posterior"]["enabled"] is False
    assert load_config(root / "config" / "config.yaml")["discrepancy"]["posterior"]["enabled"] is True


def _verdict(posterior=None):
    v = {"effect": "tyre_saturation", "ambiguous_with": [], "gap_before": 5.0, "gap_after": 0.0,
         "distributions": {"before": {"mu": {"mean": 0.8}}, "after": {"mu": {"mean": 0.99}}}, "evidence": {"seconds": 1}}
    if posterior is not None:
        v["posterior"] = posterior
    return v


@pytest.mark.parametrize("interval, r_hat, passed, status", [((0.99, 1.02), 1.01, True, "pass"), ((1.01, 1.04), 1.01, True, "fail"),
                                                             ((0.99, 1.02), 1.3, True, "fail"), ((0.99, 1.02), 1.01, False, "fail")])
def test_thesis_posterior_row(interval, r_hat, passed, status):
    lo, hi = interval
    label = {"name": "thesis_nlst", "effect": "tyre_saturation", "magnitude": 5.0, "manoeuvre": "slalom"}
    post = {"mu_mean": [0.5 * (lo + hi), lo, hi], "r_hat": {"mu_mean": r_hat}, "surrogate": {"passed": passed}}
    rows = thesis_posterior_rows(benchmark_dataset([case_outcome(label, _verdict(post))]))
    assert [r.status for r in rows] == [status]
    assert rows[0].status != "pass" or abs(rows[0].reproduced - 1.0) <= rows[0].tolerance
    assert thesis_posterior_rows(benchmark_dataset([case_outcome(label, _verdict())])) == []
    assert "moves" not in rows[0].evidence
    post["surrogate"]["shift"] = 0.2164
    assert "at most 0.216 posterior sd" in thesis_posterior_rows(benchmark_dataset([case_outcome(label, _verdict(post))]))[0].evidence
    assert len(benchmark_rows(benchmark_dataset([case_outcome(label, _verdict(post))]))) == 4

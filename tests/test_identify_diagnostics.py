"""An identification that says when it is wrong: the sampling error of the measured statistics
(influence functions, sandwich errors, the misfit's reference) and the warnings of a fit."""

import json

import numpy as np
import pytest
import yaml

from uqdrive.cli.identify import fit_notes, fit_warnings
from uqdrive.cli.main import main
from uqdrive.inference.sampling import MisfitReference, misfit_reference, run_influence, sandwich_covariance

from conftest import REPO


# -- sampling error of ensemble statistics: golden values from theory -------------------------------
@pytest.mark.parametrize("germ, kurtosis", [("normal", 3.0), ("uniform", 1.8)])
def test_influence_gives_the_sampling_variance_of_mean_and_std(germ, kurtosis):
    """Var(mean) = sigma^2 / n and Var(std) = (kurtosis - 1) sigma^2 / (4 n) (delta method): the
    influences' second moment over n^2 must give them. n = 20000 realisations of 3 independent
    times: the estimated variances carry a relative sampling error of sqrt(2 / n) (mean) and
    ~sqrt(kurt_4 / n) (std), below 3 %; tolerance 6 %. The normal and the uniform differ by a
    factor 2 / 0.8 in the std's variance, so a kurtosis-blind formula fails one of them."""
    rng = np.random.default_rng(3)
    n, sigma = 20000, 2.0
    x = rng.standard_normal((1, n, 3)) if germ == "normal" else rng.uniform(-np.sqrt(3), np.sqrt(3), (1, n, 3))
    infl = run_influence(sigma * x, np.ones((1, 3)))
    var_mean = np.sum(infl.mean**2, axis=1) / n**2
    var_std = np.sum(infl.std**2, axis=1) / n**2
    assert var_mean == pytest.approx(np.full((1, 3), sigma**2 / n), rel=0.06)
    assert var_std == pytest.approx(np.full((1, 3), (kurtosis - 1) * sigma**2 / (4 * n)), rel=0.06)


def test_sandwich_of_a_constant_mean_is_the_standard_error_of_the_grand_mean():
    """Model mean = theta at T times, data = iid runs: the least-squares estimate is the grand
    mean, whose variance is Var(run average) / n; with runs whose times are perfectly correlated
    (one germ per run) that is sigma^2 / n, not sigma^2 / (n T) (the Gauss-Newton error ignores
    the correlation in time). Tolerance: the variance estimate's sampling error sqrt(2 / n), 5 %."""
    rng = np.random.default_rng(5)
    n, T = 2000, 50
    x = np.repeat(rng.standard_normal((1, n, 1)), T, axis=2)  # each run constant in time
    jac = np.concatenate([np.ones(T), np.zeros(T)])[:, None]  # d r / d theta: mean part only
    cov = sandwich_covariance(jac, run_influence(x, np.ones((1, T))))
    assert cov[0, 0] == pytest.approx(1.0 / n, rel=0.05)


def test_misfit_reference_of_white_noise_is_the_chi_square():
    """Independent N(0, 1) runs at T times, model: one constant mean (p = 1) and a known std. The
    misfit's mean part is sum_t (m_t - mean m)^2 ~ chi2_{T-1} / n and its std part sum_t (s_t -
    1)^2 ~ chi2_T / (2 n); with only the mean fitted the expected misfit is (T - 1) / n + T / (2 n),
    within the influences' sampling error (2 %); the matched dof is near the number of
    independent terms (2 T - 1 = 79 with unequal weights: between 60 and 85)."""
    rng = np.random.default_rng(11)
    n, T = 4000, 40
    x = rng.standard_normal((1, n, T))
    jac = np.concatenate([np.ones(T), np.zeros(T)])[:, None]
    ref = misfit_reference(jac, run_influence(x, np.ones((1, T))), np.random.default_rng(0), draws=400)
    assert ref.expected == pytest.approx((T - 1) / n + T / (2 * n), rel=0.02)
    assert 60 < ref.dof < 85 and ref.threshold > ref.expected
    assert ref.p_value(ref.expected) == pytest.approx(0.5, abs=0.1)


# -- warnings of a fit: each one's trigger, and its absence -----------------------------------------
NAMES = ("mu_mean", "mu_std", "l_f_mean", "l_f_std", "F_w_mean_low", "F_w_mean_high")
BOUNDS = [(0.05, 3.0), (1e-4, 1.5), (0.05, 2.8), (1e-4, 1.5), (-5000.0, 5000.0), (-5000.0, 5000.0)]
GOOD = np.array([1.0, 0.2, 1.55, 0.2, -400.0, 400.0])
START = GOOD * 1.1
SE = np.array([0.01, 0.01, 0.01, 0.01, 10.0, 10.0])
REF = MisfitReference(expected=1.0, variance=2.0, scale=1.0, dof=1.0, level=0.99, threshold=6.63)


def test_a_sound_fit_has_no_warnings():
    assert fit_warnings(GOOD, START, BOUNDS, NAMES, True, "", SE, REF, cost=1.2, n_runs=300, start_results=[(GOOD, 1.2, True)]) == []


def test_a_mean_at_the_bound_is_a_warning_in_the_users_words():
    th = GOOD.copy()
    th[0] = 3.0
    w = fit_warnings(th, START, BOUNDS, NAMES, True, "", SE, REF, cost=1.2, n_runs=300)
    assert len(w) == 1 and "mu mean is at the upper bound 3 of the search" in w[0] and "vehicle constants" in w[0]


def test_a_std_at_zero_is_a_note_not_a_warning():
    th = GOOD.copy()
    th[3] = 1e-4
    se = SE.copy()
    se[3] = np.nan
    assert fit_warnings(th, START, BOUNDS, NAMES, True, "", se, REF, cost=1.2, n_runs=300) == []
    notes = fit_notes(NAMES, th, BOUNDS, {"l_f_std": 0.02})
    assert len(notes) == 1 and "l_f std is estimated at zero" in notes[0] and "upper bound 0.02" in notes[0]
    assert fit_notes(NAMES, GOOD, BOUNDS, {}) == []


def test_non_finite_standard_errors_are_a_warning():
    se = SE.copy()
    se[2] = np.inf
    w = fit_warnings(GOOD, START, BOUNDS, NAMES, True, "", se, REF, cost=1.2, n_runs=300)
    assert len(w) == 1 and "standard errors of l_f mean are not finite" in w[0]


def test_a_misfit_beyond_its_threshold_names_the_vehicle_constants():
    w = fit_warnings(GOOD, START, BOUNDS, NAMES, True, "", SE, REF, cost=30.0, n_runs=300)
    assert len(w) == 1 and w[0].startswith("the misfit is 30 times the noise") and "check mass" in w[0]
    assert fit_warnings(GOOD, START, BOUNDS, NAMES, True, "", SE, REF, cost=6.6, n_runs=300) == []  # just under the threshold


def test_starts_that_disagree_beyond_their_errors_are_a_warning():
    other = GOOD.copy()
    other[2] += 0.05  # 5 standard errors away, equally good misfit
    w = fit_warnings(GOOD, START, BOUNDS, NAMES, True, "", SE, REF, cost=1.2, n_runs=300, start_results=[(GOOD, 1.2, True), (other, 1.5, True)])
    assert len(w) == 1 and "starts disagree" in w[0] and "l_f mean 1.6" in w[0]
    # the same point with a clearly worse misfit is a local optimum, not a disagreement; 2 SE apart is agreement
    worse = fit_warnings(GOOD, START, BOUNDS, NAMES, True, "", SE, REF, cost=1.2, n_runs=300, start_results=[(GOOD, 1.2, True), (other, 9.0, True)])
    near = GOOD.copy()
    near[2] += 0.02
    close = fit_warnings(GOOD, START, BOUNDS, NAMES, True, "", SE, REF, cost=1.2, n_runs=300, start_results=[(GOOD, 1.2, True), (near, 1.2, True)])
    assert worse == [] and close == []


# -- end to end: the right car converges, the wrong car says so ------------------------------------
def _car(tmp_path, name, scale_J0=1.0):
    cfg = yaml.safe_load((REPO / "config" / "test.yaml").read_text())
    cfg["time"].update(dt=0.05, step=0.025)
    cfg["vehicle"]["J0"] *= scale_J0
    path = tmp_path / f"{name}.yaml"
    path.write_text(yaml.safe_dump(cfg))
    return str(path)


@pytest.mark.long(8)
def test_the_wrong_car_is_not_converged_and_the_warning_names_the_vehicle_constants(tmp_path, capsys):
    """Ensembles (400 realisations) of a car with 1.5 x the yaw inertia, identified with the
    packaged car: converged false and a warning naming the vehicle constants, printed on stderr.
    The same data identified with their own car: converged, no warning (the control)."""
    right, wrong = _car(tmp_path, "inertia_x1.5", 1.5), _car(tmp_path, "packaged", 1.0)
    data = tmp_path / "car.nc"
    assert main(["simulate", "--model", "lst", "--samples", "400", "--config", right, "--out", str(data)]) == 0
    assert main(["identify", str(data), "--config", right, "--out", str(tmp_path / "right"), "--m-load", "100"]) == 0
    ok = json.loads((tmp_path / "right" / "estimate.json").read_text())
    assert ok["converged"] is True and ok["warnings"] == [], ok["warnings"]
    assert ok["goodness_of_fit"]["passed"] is True
    capsys.readouterr()
    assert main(["identify", str(data), "--config", wrong, "--out", str(tmp_path / "wrong"), "--m-load", "100"]) == 0
    bad = json.loads((tmp_path / "wrong" / "estimate.json").read_text())
    assert bad["converged"] is False and bad["goodness_of_fit"]["passed"] is False
    assert any("times the noise" in w and "yaw inertia" in w for w in bad["warnings"])
    err = capsys.readouterr().err
    assert "uqdrive: warning: the misfit is" in err


def test_discover_baseline_at_the_mu_bound_is_a_warning(config):
    """discover's baseline at mu mean = 3.0 (the upper end of its box) is a warning in the verdict's
    words; inside the box, or with a std at zero, there is none; a known l_f is not checked."""
    import copy
    from types import SimpleNamespace

    from uqdrive.cli.discover import baseline_warnings

    from uqdrive.settings import Settings

    def finder(theta, cfg=config, success=True):
        return SimpleNamespace(baseline_=SimpleNamespace(theta_=np.array(theta, float), success_=success, message_="stopped"),
                               settings=Settings.from_config(cfg))

    inside = [1.1, 0.2, 1.5, 0.0, -380.0, 410.0]
    assert baseline_warnings(finder(inside)) == []
    w = baseline_warnings(finder([3.0, 0.2, 1.5, 0.2, -380.0, 410.0]))
    assert len(w) == 1 and w[0].startswith("baseline fit: ") and "mu mean is at the upper bound 3 of the search" in w[0]
    assert "without converging: stopped" in baseline_warnings(finder(inside, success=False))[0]
    known = copy.deepcopy(config)
    known["uncertainty"]["l_f"]["std"] = 0.0
    assert baseline_warnings(finder([1.1, 0.2, 2.5, 0.0, -380.0, 410.0], known)) == []  # l_f at 2.5 = its bound, but known
    assert baseline_warnings(finder([1.1, 0.2, 2.5, 0.1, -380.0, 410.0])) != []

"""The estimator on exact model data: it must find the truth, guard physics, report failures."""

from types import SimpleNamespace

import numpy as np
import pytest
from scipy.optimize import OptimizeResult

from hypothesis import given, settings
from hypothesis import strategies as st

from uqdrive.inference.identify import COSTS, OPTIMISERS, STATE_SCALES, DistributionEstimator, WeightContext, cost_weights, default_bounds, initial_guess, state_weights
from uqdrive.vehicle.chaos import LSTChaosModel
from uqdrive.settings import Settings

TRUTH = np.array([1.0, 0.2, 1.55, 0.2, -400.0, 400.0])


# -- estimator logic on a model linear in its parameters (exact answers in closed form, fast) -----
class LinearToy:
    """A MomentModel whose moments are linear in the parameters: mean = mu a + F_low b + F_high c
    (4 states x T), std = |sigma| s. Weighted least squares then has a closed form, and the cost
    is exactly quadratic (sigma > 0), so central second differences are exact Hessians. The names
    are the real ones, so the |sigma| report and the wind ordering of the global stage apply."""

    theta_names = ("mu_mean", "mu_std", "F_w_mean_low", "F_w_mean_high")

    def __init__(self, T=40, wind=1e-3, vjp=False, dead_wind=False):
        t = np.linspace(0.0, 4.0, T)
        self.a = np.stack([np.sin(t), np.cos(t), 0.5 * t, np.exp(-t)])
        self.b = wind * np.stack([1 - np.exp(-t), np.sin(2 * t), t, np.ones_like(t)])
        self.c = 0.0 * t if dead_wind else wind * np.stack([t**2 / 8, np.cos(3 * t), -t, np.tanh(t)])
        self.c = np.broadcast_to(self.c, self.a.shape)
        self.s = 0.5 + 0.3 * np.stack([np.sin(t) ** 2, t / 4, np.exp(-t), np.cos(t) ** 2])
        if vjp:
            self.moments_vjp = self._moments_vjp

    def moments(self, theta, gradient=False):
        th = np.asarray(theta, float)
        mean = th[0] * self.a + th[2] * self.b + th[3] * self.c
        var = th[1] ** 2 * self.s**2
        out = SimpleNamespace(mean=mean, variance=var, std=np.sqrt(var), mean_gradient=None, variance_gradient=None)
        if gradient:
            z = np.zeros_like(self.a)
            out.mean_gradient = np.stack([self.a, z, self.b, self.c])
            out.variance_gradient = np.stack([z, 2 * th[1] * self.s**2, z, z])
        return out

    def _moments_vjp(self, theta):
        r = self.moments(theta, gradient=True)
        return r, lambda dm, dv: np.einsum("pij,ij->p", r.mean_gradient, dm) + np.einsum("pij,ij->p", r.variance_gradient, dv)

    def least_squares(self, mean, std, w):
        """The exact minimiser of sum w [(mean error)^2 + (std error)^2]: weighted linear least
        squares for (mu, F_low, F_high), and sigma = sum w s std / sum w s^2."""
        X = np.stack([self.a.ravel(), self.b.ravel(), self.c.ravel()], axis=1)
        W = w.ravel()
        th = np.linalg.solve(X.T @ (W[:, None] * X), X.T @ (W * mean.ravel()))
        return np.array([th[0], np.sum(w * self.s * std) / np.sum(w * self.s**2), th[1], th[2]])


TOY_TRUTH = np.array([1.0, 0.2, -400.0, 400.0])
TOY_START = TOY_TRUTH * np.array([1.25, 0.75, 1.3, 0.7])  # 25-30 % away from the truth
STEER = WeightContext(0.3 * np.sin(np.linspace(0.0, 6.0, 40)))


@pytest.fixture(scope="module")
def toy_data():
    """Non-exact data: the toy's moments at the truth with 5 % noise (mean: 0.05 absolute)."""
    r = LinearToy().moments(TOY_TRUTH)
    rng = np.random.default_rng(0)
    return r.mean + 0.05 * rng.normal(size=r.mean.shape), r.std * (1 + 0.05 * rng.normal(size=r.std.shape))


def _direct_cost(model, theta, mean, std, w):
    r = model.moments(theta)
    return float(np.sum(w * ((r.mean - mean) ** 2 + (np.sqrt(r.variance) - std) ** 2)))


@pytest.mark.parametrize("optimiser, vjp", [("lbfgsb", False), ("lbfgsb", True), ("gauss_newton", False)])
def test_weights_multiply_and_the_fit_is_the_weighted_least_squares_optimum(toy_data, optimiser, vjp):
    """INP weights exp(-|u|) times the per-state 1/RMS(mean)^2, on non-exact data: the cost equals
    sum w [(mean error)^2 + (std error)^2] with w the product (rel 1e-12 at two points), and the
    fit from 25-30 % away equals the closed-form weighted least squares (L-BFGS-B: rel 1e-7, it
    stops at a relative cost reduction of 1e-15, measured 2.5e-10; Gauss-Newton: rel 1e-10).
    Weights combined by a sum move the optimum by 2.6e-3 relative."""
    mean, std = toy_data
    model = LinearToy(vjp=vjp)
    w = np.exp(-np.abs(STEER.delta))[None, :] / np.mean(mean**2, axis=1)[:, None]
    est = DistributionEstimator(model, "inp", state_scale="rms_mean", optimiser=optimiser).fit(mean, std, TOY_START, STEER)
    for theta in (TOY_START, TOY_TRUTH):
        assert est.cost_function(theta) == pytest.approx(_direct_cost(model, theta, mean, std, w), rel=1e-12)
    best = model.least_squares(mean, std, w)
    assert est.converged_ and "restart" not in est.message_
    assert est.theta_ == pytest.approx(best, rel=1e-7 if optimiser == "lbfgsb" else 1e-10)
    assert est.cost_ == pytest.approx(_direct_cost(model, best, mean, std, w), rel=1e-12)
    assert est.moments_.mean == pytest.approx(model.moments(est.theta_).mean, rel=1e-12)
    assert est.n_iter_ > 0 and est.n_eval_ >= est.n_iter_


@pytest.mark.parametrize("vjp", [False, True])
def test_objective_gradient_equals_central_differences(toy_data, vjp):
    """Both gradient paths (forward sensitivities, and the model's vector-Jacobian product) equal
    central differences of the cost, and the optimiser's scaled pair (J / J0, g scale / J0) is
    consistent: the cost is quadratic, so differences with h = 1e-3 |theta| are exact to
    rounding (~1e-16 J / h ~ 1e-10 relative); tolerance 1e-7 relative."""
    mean, std = toy_data
    est = DistributionEstimator(LinearToy(vjp=vjp), "inp", state_scale="rms_std").fit(mean, std, TOY_START, STEER)
    theta = TOY_START
    J, g, _ = est._objective(theta)
    h = 1e-3 * np.abs(theta)
    fd = np.array([(est.cost_function(theta + e) - est.cost_function(theta - e)) / (2 * e.max()) for e in np.diag(h)])
    assert J == pytest.approx(est.cost_function(theta), rel=1e-14) and g == pytest.approx(fd, rel=1e-7)
    z = theta / est._scale
    Js, gs = est._scaled(z)
    assert Js == pytest.approx(J / est._J0, rel=1e-14) and gs == pytest.approx(g * est._scale / est._J0, rel=1e-14)
    assert est._J0 == pytest.approx(est.cost_function(TOY_START), rel=1e-14) and np.array_equal(est._scale, np.abs(TOY_START))


def test_error_bars_equal_the_finite_difference_hessian(toy_data):
    """theta_std_ = sqrt(diag(s^2 (J'J)^-1)), s^2 = cost / (n - p): for a sum of squares the
    Hessian is 2 J'J when the residuals are linear in theta, as here, so theta_std_ must equal
    sqrt(diag(2 s^2 H^-1)) with H from central second differences of the cost (exact for a
    quadratic up to rounding; tolerance 1e-6 relative). n = 2 x 4 x 40 residuals, p = 4."""
    mean, std = toy_data
    est = DistributionEstimator(LinearToy(), "std", optimiser="gauss_newton").fit(mean, std, TOY_START)
    th, p = est.theta_, 4
    h = 1e-3 * np.abs(th)
    E = np.diag(h)
    f = est.cost_function
    H = np.array([[(f(th + E[i] + E[j]) - f(th + E[i] - E[j]) - f(th - E[i] + E[j]) + f(th - E[i] - E[j])) / (4 * h[i] * h[j]) for j in range(p)] for i in range(p)])
    s2 = est.cost_ / (2 * mean.size - p)
    assert est.theta_std_ == pytest.approx(np.sqrt(np.diag(2 * s2 * np.linalg.inv(H))), rel=1e-6)
    assert np.all(est.theta_std_ < 0.05 * np.abs(th))  # informative data: a few % at most


def test_unidentifiable_parameter_gives_nan_error_bars(toy_data):
    """F_high has no effect on the moments: J'J is singular and the error bars are NaN (the fit
    itself still converges and leaves F_high at its start)."""
    mean, std = toy_data
    est = DistributionEstimator(LinearToy(dead_wind=True), "std", optimiser="gauss_newton").fit(mean, std, TOY_START)
    assert est.theta_std_.shape == (4,) and np.all(np.isnan(est.theta_std_))
    assert est.theta_[3] == pytest.approx(TOY_START[3], rel=1e-12)


def _scripted(monkeypatch, *steps):
    """Replace the L-BFGS-B entry of the registry: call i runs steps[i](real, problem, z0, box) (the
    real optimiser after the script ends); returns the list of results, in call order."""
    from uqdrive.inference import identify

    real, calls = identify.OPTIMISERS["lbfgsb"], []

    def optimiser(problem, z0, box):
        step = steps[len(calls)] if len(calls) < len(steps) else (lambda real, problem, z0, box: real(problem, z0, box))
        calls.append(step(real, problem, z0, box))
        return calls[-1]

    monkeypatch.setitem(identify.OPTIMISERS, "lbfgsb", optimiser)
    return calls


def _stop_at(z, problem, message="ABNORMAL_TERMINATION_IN_LNSRCH", nit=0, nfev=1):
    return OptimizeResult(x=np.array(z, float), fun=problem.cost(np.array(z, float))[0], nit=nit, nfev=nfev, success=False, message=message)


def test_restart_after_an_abnormal_stop_reaches_the_optimum(toy_data, monkeypatch):
    """A forced abnormal stop at the start (as when the first line search fails): the restart
    from there must run, converge, be reported, and its iterations counted."""
    mean, std = toy_data
    calls = _scripted(monkeypatch, lambda real, problem, z0, box: _stop_at(z0, problem, nit=3, nfev=7))
    est = DistributionEstimator(LinearToy(), "std").fit(mean, std, TOY_START)
    assert len(calls) == 2 and calls[1].success
    assert est.converged_ and "after a restart from an abnormal stop" in est.message_
    assert est.theta_ == pytest.approx(LinearToy().least_squares(mean, std, np.ones_like(mean)), rel=1e-7)
    assert (est.n_iter_, est.n_eval_) == (3 + calls[1].nit, 7 + calls[1].nfev)


def test_restart_that_stays_put_is_stationary_to_precision(toy_data, monkeypatch):
    """Both runs reach the optimum but report an abnormal stop: the restart changed the cost by
    < 1e-9, so the fit is accepted as stationary (converged, said so in the message)."""
    mean, std = toy_data

    def abnormal_optimum(real, problem, z0, box):
        res = real(problem, z0, box)
        res.success, res.message = False, "ABNORMAL_TERMINATION_IN_LNSRCH"
        return res

    calls = _scripted(monkeypatch, abnormal_optimum, abnormal_optimum)
    est = DistributionEstimator(LinearToy(), "std").fit(mean, std, TOY_START)
    assert len(calls) == 2 and calls[1].fun == pytest.approx(calls[0].fun, rel=1e-9)
    assert est.converged_ and "stationary to precision" in est.message_


def test_restart_that_does_not_settle_is_not_convergence(toy_data, monkeypatch):
    """An abnormal stop whose restart moves the cost by more than 1e-9 is not convergence: a
    warning, converged_ False, and the better of the two points is kept (the restart's when it
    improved, the first stop's when the restart ended worse)."""
    mean, std = toy_data
    z_opt = LinearToy().least_squares(mean, std, np.ones_like(mean)) / np.abs(TOY_START)
    z_start = TOY_START / np.abs(TOY_START)
    halfway = 0.5 * (z_start + z_opt)
    for second, expected in ((halfway, halfway), (z_start + 0.3 * (z_start - z_opt), z_start)):
        _scripted(monkeypatch, lambda real, problem, z0, box: _stop_at(z0, problem), lambda real, problem, z0, box, z=second: _stop_at(z, problem))
        with pytest.warns(RuntimeWarning, match="did not converge"):
            est = DistributionEstimator(LinearToy(), "std").fit(mean, std, TOY_START)
        assert not est.converged_
        assert est.theta_ == pytest.approx(np.abs(expected * np.abs(TOY_START)) * [1, 1, -1, 1], rel=1e-12)


def test_gauss_newton_treats_non_finite_moments_as_non_physical(toy_data):
    """Evaluations where the model returns a NaN mean (the 2nd, at the start, and the 6th) or a NaN
    sensitivity with a finite mean (the 4th, a trial point) cost the penalty and are rejected,
    like a model that raises; the fit still reaches the closed-form optimum (rel 1e-10)."""
    mean, std = toy_data

    class Glitchy(LinearToy):
        calls = 0

        def moments(self, theta, gradient=False):
            Glitchy.calls += 1
            r = super().moments(theta, gradient)
            if Glitchy.calls in (2, 6):
                r.mean = r.mean.copy()
                r.mean[0, 3] = np.nan
            if Glitchy.calls == 4 and gradient:
                r.mean_gradient = r.mean_gradient.copy()
                r.mean_gradient[0, 1, 2] = np.nan
            return r

    est = DistributionEstimator(Glitchy(), "std", optimiser="gauss_newton").fit(mean, std, TOY_START)
    assert Glitchy.calls > 6 and est.converged_
    assert est.theta_ == pytest.approx(LinearToy().least_squares(mean, std, np.ones_like(mean)), rel=1e-10)

def test_iteration_limit_is_not_convergence(toy_data):
    """Gauss-Newton limited to 2 evaluations per start stops on the limit (status 0): that is not
    convergence (warned), whatever the restart does."""
    mean, std = toy_data
    with pytest.warns(RuntimeWarning, match="did not converge"):
        est = DistributionEstimator(LinearToy(), "std", optimiser="gauss_newton", max_iter=2).fit(mean, std, TOY_START)
    assert not est.converged_ and "maximum number of function evaluations" in est.message_


@pytest.mark.parametrize("optimiser", ["lbfgsb", "gauss_newton"])
def test_optimisers_report_the_scaled_cost_they_stopped_at(toy_data, optimiser):
    """Starts and the penalty are compared through ``fun``: every registered optimiser must
    return the scaled cost J / J0 at its x (rel 1e-10), from a start 25-30 % away."""
    from uqdrive.inference import identify

    mean, std = toy_data
    est = DistributionEstimator(LinearToy(), "std", optimiser=optimiser).fit(mean, std, TOY_START)
    lo, hi = np.array(est.bounds, float).T
    problem = est.problem_
    res = identify.OPTIMISERS[optimiser](problem, TOY_START / problem.scale, list(zip(lo / problem.scale, hi / problem.scale)))
    assert res.success and res.fun == pytest.approx(problem.cost(res.x)[0], rel=1e-10)
    assert res.fun < 0.1  # well below the start's 1


def test_start_at_the_optimum_converges_in_place(toy_data):
    """Starting at the exact optimum (scaled cost 1 there): converged, and the estimate stays put."""
    mean, std = toy_data
    best = LinearToy().least_squares(mean, std, np.ones_like(mean))
    est = DistributionEstimator(LinearToy(), "std").fit(mean, std, best)
    assert est.converged_ and est.theta_ == pytest.approx(best, rel=1e-9)


def test_sigma_is_reported_as_its_absolute_value(toy_data):
    """The cost is even in sigma: from a negative start (box allowing it) the fit stops at -sigma
    and reports |sigma|; means keep their sign (F_low stays negative)."""
    mean, std = toy_data
    bounds = [(0.05, 3.0), (-1.5, 1.5), (-5000.0, 5000.0), (-5000.0, 5000.0)]
    start = TOY_START * [1, -1, 1, 1]
    est = DistributionEstimator(LinearToy(), "std", bounds=bounds).fit(mean, std, start)
    assert est.theta_ == pytest.approx(LinearToy().least_squares(mean, std, np.ones_like(mean)), rel=1e-7)
    assert est.theta_[1] > 0 and est.theta_[2] < 0


def test_global_stage_candidates(toy_data):
    """The global stage returns the ``starts`` best random points of the box, best first, inside
    the box, with the mean-wind pair ordered low < high. The toy's wind columns are scaled down
    (1e-7) so the cost barely depends on their order: only the explicit ordering can make every
    candidate ordered. Without a generator the stage is seeded 0 (reproducible)."""
    mean, std = toy_data
    model = LinearToy(wind=1e-7)
    lo, hi = np.array(default_bounds(model.theta_names, 2.85)).T
    for starts in (1, 6):
        est = DistributionEstimator(model, "std", starts=starts, rng=np.random.default_rng(3)).fit(mean, std, TOY_START)
        cand = est._global_candidates()
        assert len(cand) == starts
        costs = [est.cost_function(c) for c in cand]
        assert costs == sorted(costs)
        for c in cand:
            assert np.all(c >= lo) and np.all(c <= hi) and c[2] < c[3]
    a = DistributionEstimator(model, "std", starts=2).fit(mean, std, TOY_START)
    b = DistributionEstimator(model, "std", starts=2, rng=np.random.default_rng(0)).fit(mean, std, TOY_START)
    assert np.array_equal(a.theta_, b.theta_) and a.n_eval_ == b.n_eval_
    assert DistributionEstimator(model, "std", starts=0)._global_candidates() == []


def test_defaults_and_configured_choices(config):
    """Defaults: the thesis' single local fit (no global stage), L-BFGS-B, SI units, STD weights;
    the config selects state scales and the optimiser; the physical boxes of default_bounds."""
    est = DistributionEstimator(LinearToy())
    assert (est.starts, est.optimiser, est.state_scale, est.cost) == (0, "lbfgsb", "none", "std")
    assert Settings.from_config(config).identify.scale() == "none" and Settings.from_config(config).identify.scale(normalised=True) == "rms_mean"
    assert Settings.from_config(config).identify.optimiser == "lbfgsb"
    names = ("mu_mean", "mu_std", "l_f_mean", "l_f_std", "m_load_mean", "m_load_std", "F_w_mean_low", "F_w_mean_high")
    assert np.array(default_bounds(names, 2.6)) == pytest.approx(np.array([(0.05, 3.0), (1e-4, 1.5), (0.05, 2.55), (1e-4, 1.5), (-500.0, 2000.0), (1e-2, 500.0), (-5000.0, 5000.0), (-5000.0, 5000.0)]), rel=1e-14)
    assert DistributionEstimator(LinearToy()).bounds == default_bounds(LinearToy.theta_names, 2.85)
    with pytest.raises(ValueError, match="unknown cost 'l1'"):
        DistributionEstimator(LinearToy(), cost="l1")


def test_non_finite_moments_are_not_physical(toy_data):
    """A model that returns NaN means (mu > 2) or NaN variances (sigma > 1) has no cost there:
    cost_function is inf (not NaN), whichever of the two is broken."""
    mean, std = toy_data

    class Diverging(LinearToy):
        def moments(self, theta, gradient=False):
            r = super().moments(theta, gradient)
            if theta[0] > 2.0:
                r.mean = np.full_like(r.mean, np.nan)
            if theta[1] > 1.0:
                r.variance = np.full_like(r.variance, np.nan)
            return r

    est = DistributionEstimator(Diverging(), "std").fit(mean, std, TOY_START)
    assert np.isfinite(est.cost_function(TOY_START))
    assert est.cost_function(TOY_START * [2.5, 1, 1, 1]) == np.inf
    assert est.cost_function(TOY_START * [1, 8, 1, 1]) == np.inf

def test_measured_arrays_must_be_two_dimensional_and_alike(toy_data):
    mean, std = toy_data
    with pytest.raises(ValueError, match="shape"):
        DistributionEstimator(LinearToy()).fit(mean, std[:, :-1], TOY_START)
    with pytest.raises(ValueError, match="shape"):
        DistributionEstimator(LinearToy()).fit(mean[0], std[0], TOY_START)


def test_scale_values_and_non_finite_scales():
    """rms_mean = sqrt(mean over time of mean^2) per state, rms_std likewise; weights 1 / scale^2;
    an infinite scale is an error like a zero one."""
    mean = np.array([[3.0, 4.0], [1.0, 1.0]])
    std = np.array([[1.0, 1.0], [0.0, 2.0]])
    assert state_weights("rms_mean", mean, std) == pytest.approx([1 / 12.5, 1.0], rel=1e-14)
    assert state_weights("rms_std", mean, std) == pytest.approx([1.0, 0.5], rel=1e-14)
    with pytest.raises(ValueError, match="zero or not finite"):
        state_weights("rms_mean", np.array([[np.inf, 1.0], [1.0, 1.0]]), std)


# -- the vehicle PCE model ----------------------------------------------------------------------

@pytest.fixture(scope="module")
def model(config):
    return LSTChaosModel(Settings.from_config(config), uncertain=("mu", "l_f", "F_w_mean"), time_variant_wind=False)


@pytest.fixture(scope="module")
def data(model):
    r = model.moments(TRUTH)
    return r.mean, r.std


def test_recovers_the_truth_from_model_data(model, data):
    """Data made by the model itself, from 20-25 % away: the optimum is the truth. L-BFGS-B stops
    at a relative cost reduction of 1e-15; over 9 starts and all state scales it was within
    2e-7 of the truth, so 1e-5 relative on every parameter (no absolute slack: the wind's 400 N
    must be right to 4 mN). With zero residual the error bars vanish (s^2 = cost / (n - p))."""
    th0 = initial_guess(TRUTH, 0.2, 0.25, np.random.default_rng(1))
    est = DistributionEstimator(model, "std").fit(*data, th0)
    assert est.converged_
    assert est.theta_ == pytest.approx(TRUTH, rel=1e-5)
    assert np.all(est.theta_std_ < 1e-4 * np.abs(TRUTH))


@pytest.mark.parametrize("scale", sorted(STATE_SCALES))
def test_recovers_the_truth_with_every_state_scale(model, data, scale):
    """Exact model data, from 20-25 % away: rescaling the residuals per state must not move the
    optimum (1e-5 relative, as above)."""
    th0 = initial_guess(TRUTH, 0.2, 0.25, np.random.default_rng(2))
    est = DistributionEstimator(model, "std", state_scale=scale).fit(*data, th0)
    assert est.theta_ == pytest.approx(TRUTH, rel=1e-5)


def test_gauss_newton_reaches_the_quasi_newton_optimum(model, data):
    """Perturbed data (a non-zero residual at the optimum, as with measured data): trust-region
    Gauss-Newton and L-BFGS-B stop at the same optimum (parameters 1e-4 relative, cost 1e-8),
    Gauss-Newton in fewer iterations (J'J is the Hessian model a sum of squares offers), from
    20-25 % away.

    Error bars: s^2 (J'J)^-1 against 2 s^2 H^-1 with H the central-difference Hessian of the cost
    (h = 1e-4 |theta|). The Gauss-Newton Hessian 2 J'J omits sum r_i grad^2 r_i, small for 2 %
    residuals (measured 7e-4 relative); tolerance 1e-2."""
    mean, std = data
    rng = np.random.default_rng(7)
    noisy = (mean * (1 + 0.02 * rng.normal(size=mean.shape)), std * (1 + 0.02 * rng.normal(size=std.shape)))
    th0 = initial_guess(TRUTH, 0.2, 0.25, np.random.default_rng(3))
    fits = {name: DistributionEstimator(model, "std", state_scale="rms_mean", optimiser=name).fit(*noisy, th0) for name in OPTIMISERS}
    qn, gn = fits["lbfgsb"], fits["gauss_newton"]
    assert qn.converged_ and gn.converged_
    assert gn.theta_ == pytest.approx(qn.theta_, rel=1e-4)
    assert gn.cost_ == pytest.approx(qn.cost_, rel=1e-8)
    assert gn.n_iter_ < qn.n_iter_
    th, p, f = gn.theta_, TRUTH.size, gn.cost_function
    E = np.diag(1e-4 * np.abs(th))
    H = np.zeros((p, p))
    for i in range(p):
        for j in range(i, p):
            H[i, j] = H[j, i] = (f(th + E[i] + E[j]) - f(th + E[i] - E[j]) - f(th - E[i] + E[j]) + f(th - E[i] - E[j])) / (4 * E[i, i] * E[j, j])
    s2 = gn.cost_ / (2 * mean.size - p)
    assert gn.theta_std_ == pytest.approx(np.sqrt(np.diag(2 * s2 * np.linalg.inv(H))), rel=1e-2)
    assert qn.theta_std_ == pytest.approx(gn.theta_std_, rel=1e-3)


def test_gauss_newton_rejects_non_physical_steps(model, data):
    """Trial points where the model cannot be evaluated (here: the 2nd and 5th, as a model
    raises outside its physical region) cost the penalty and are rejected; the fit still
    reaches the truth (exact data, 1e-5 as above; Gauss-Newton gets to ~1e-12), from 20-25 %."""

    class Refusing:
        theta_names = model.theta_names

        def __init__(self):
            self.calls, self.refused = 0, 0

        def moments(self, theta, gradient=False):
            self.calls += 1
            if gradient and self.calls in (2, 5):
                self.refused += 1
                raise ValueError("outside the physical region")
            return model.moments(theta, gradient=gradient)

    refusing = Refusing()
    th0 = initial_guess(TRUTH, 0.2, 0.25, np.random.default_rng(4))
    est = DistributionEstimator(refusing, "std", optimiser="gauss_newton").fit(*data, th0)
    assert refusing.refused == 2
    assert est.converged_
    assert est.theta_ == pytest.approx(TRUTH, rel=1e-5)


def test_unknown_optimiser_is_named():
    with pytest.raises(ValueError, match="unknown optimiser 'newton'; choose one of lbfgsb, gauss_newton"):
        DistributionEstimator(object(), optimiser="newton", wheelbase=2.85)


@settings(max_examples=30, deadline=None)
@given(st.lists(st.floats(1e-3, 1e3), min_size=4, max_size=4), st.sampled_from(["rms_mean", "rms_std"]))
def test_unit_free_scales_make_the_cost_independent_of_units(units, scale):
    """Expressing state i in other units (factor c_i) scales its residuals by c_i and its weight
    by 1/c_i^2, so every weighted squared residual is unchanged (relative 1e-12)."""
    rng = np.random.default_rng(0)
    mean, std, resid = rng.normal(size=(4, 50)), rng.uniform(0.1, 1, (4, 50)), rng.normal(size=(4, 50))
    c = np.array(units)[:, None]
    before = state_weights(scale, mean, std)[:, None] * resid**2
    after = state_weights(scale, c * mean, c * std)[:, None] * (c * resid) ** 2
    assert after == pytest.approx(before, rel=1e-12)


def test_state_scale_errors_name_the_problem():
    with pytest.raises(ValueError, match="unknown state scale 'max'"):
        state_weights("max", np.ones((4, 3)), np.ones((4, 3)))
    with pytest.raises(ValueError, match="unknown state scale 'max'"):
        DistributionEstimator(object(), state_scale="max", wheelbase=2.85)
    zero = np.ones((4, 3))
    zero[2] = 0.0
    with pytest.raises(ValueError, match="state scale 'rms_mean' is zero"):
        state_weights("rms_mean", zero, np.ones((4, 3)))
    assert state_weights("none", zero, zero) == pytest.approx(np.ones(4))


def test_initial_guess_bounds_5_34():
    g = initial_guess(TRUTH, 0.1, 0.1, np.random.default_rng(0))
    assert np.abs(np.abs(g / TRUTH - 1) - 0.1) == pytest.approx(np.zeros(6), abs=1e-12)
    g = initial_guess(TRUTH, 0.0, 0.25, np.random.default_rng(0))
    assert np.all(np.abs(g / TRUTH - 1) <= 0.25)
    g = initial_guess(np.ones(64), 0.2, 0.25, np.random.default_rng(1))
    assert (g > 1).any() and (g < 1).any()  # both directions (5.34): sign uniform on {-1, +1}


def test_weights():
    ctx = WeightContext(delta=np.array([0.0, 0.5, -0.5]), kl_divergence=np.array([[np.nan, 1.0, -1e-3]] * 4))
    assert cost_weights("std", ctx, (4, 3)) == pytest.approx(np.ones((4, 3)))
    assert cost_weights("inp", ctx, (4, 3)) == pytest.approx(np.tile([1.0, np.exp(-0.5), np.exp(-0.5)], (4, 1)), rel=1e-14)
    assert cost_weights("dst", ctx, (4, 3))[0] == pytest.approx([1.0, np.exp(-1.0), np.exp(-1e-3)], rel=1e-14)  # |D_KL|: rounding can make it < 0
    with pytest.raises(ValueError, match="KL divergence"):
        cost_weights("dst", WeightContext(np.zeros(2)), (4, 2))
    with pytest.raises(ValueError, match="unknown cost 'l1'"):
        cost_weights("l1", ctx, (4, 3))
    assert set(COSTS) == {"std", "inp", "dst"}
    with pytest.raises(AttributeError):
        ctx.delta = np.zeros(3)  # frozen: a context is shared by every start of a fit


def test_non_physical_start_is_a_clear_error(model, data):
    bad = TRUTH.copy()
    bad[0] = 0.2  # mu mean 0.2 with std 0.2: negative friction at the outer quadrature nodes
    with pytest.raises(ValueError, match="not physical"):
        DistributionEstimator(model, "std").fit(*data, bad)


def test_guarded_search_stays_physical(model, data):
    """Scaled data pulls the fit towards negative friction: the guard keeps it physical."""
    est = DistributionEstimator(model, "std", max_iter=60).fit(data[0] * 3.0, data[1] * 0.1, TRUTH)
    lo, hi = np.array(default_bounds(model.theta_names, 2.85)).T
    assert np.all(est.theta_ >= lo - 1e-9) and np.all(est.theta_ <= hi + 1e-9)
    assert est.theta_[0] - 2.4 * est.theta_[1] > 0  # mu > 0 at the outer Gauss-Hermite node


def test_multistart_reaches_the_optimum_from_far(model, data):
    """From 90 % away (where a single local fit stops with l_f_std 66 % off) the global stage's
    best 3 points lead to the truth: 1e-5 relative on every parameter (measured 5e-7)."""
    th0 = initial_guess(TRUTH, 0.9, 0.9, np.random.default_rng(5))
    th0[0] = max(th0[0], 0.6)  # keep the start physical; the global stage does the rest
    th0[1] = min(th0[1], 0.2)
    lo, hi = sorted(th0[4:])
    th0[4], th0[5] = lo, hi
    est = DistributionEstimator(model, "std", starts=3, rng=np.random.default_rng(0)).fit(*data, th0)
    assert est.converged_ and est.theta_ == pytest.approx(TRUTH, rel=1e-5)

"""The LST Galerkin PCE against Monte Carlo, finite differences, chaospy and SALib."""

import numpy as np
import pytest

from uqdrive.vehicle.montecarlo import lst_response, simulate_ensemble
from uqdrive.vehicle.chaos import LSTChaosModel
from uqdrive.vehicle.statistics import ensemble_statistics
from uqdrive.settings import Settings


@pytest.fixture(scope="module")
def full_model(config):
    return LSTChaosModel(Settings.from_config(config))


@pytest.fixture(scope="module")
def ident_model(config):
    return LSTChaosModel(Settings.from_config(config), uncertain=("mu", "l_f", "F_w_mean"), time_variant_wind=False, fixed={"m_load": 110.0})


def test_pce_agrees_with_2000_run_monte_carlo(config, full_model):
    """All uncertainties incl. the KLE wind, N_PCE = 2, 4 points. Tolerances are in standard
    errors of the 2000-run ensemble: sigma / sqrt(N) for the mean and sigma / sqrt(2 (N - 1))
    for the std, at every time after t = 0. Measured: |z| <= 1.6 (mean), <= 4.3 (std; the
    order-2 truncation contributes about 1 % of sigma, see the convergence figure)."""
    N = 2000
    mc = ensemble_statistics(simulate_ensemble(Settings.from_config(config), "lst", samples=N), "keep")
    r = full_model.moments(Settings.from_config(config).uncertainty.theta(full_model.uncertain))
    s = mc["std"].values[:, 1:]
    z_mean = np.abs(r.mean[:, 1:] - mc["mean"].values[:, 1:]) / (s / np.sqrt(N))
    z_std = np.abs(r.std[:, 1:] - s) / (s / np.sqrt(2 * (N - 1)))
    assert z_mean.max() < 4.0
    assert z_std.max() < 5.0


def test_gradient_matches_finite_differences(config, ident_model):
    theta = np.array([0.9, 0.25, 1.5, 0.18, -300.0, 450.0])
    r = ident_model.moments(theta, gradient=True)
    for p in range(theta.size):
        h = 1e-6 * max(1.0, abs(theta[p]))
        e = np.zeros_like(theta)
        e[p] = h
        up, down = ident_model.moments(theta + e), ident_model.moments(theta - e)
        for got, fd in ((r.mean_gradient[p], (up.mean - down.mean) / (2 * h)), (r.variance_gradient[p], (up.variance - down.variance) / (2 * h))):
            assert np.abs(got - fd).max() <= 1e-6 * np.abs(fd).max() + 1e-12, ident_model.theta_names[p]


def test_against_chaospy_pseudo_spectral(config):
    """A non-intrusive pseudo-spectral PCE (chaospy, Gauss quadrature on the same germs, order
    4) and uqdrive's intrusive Galerkin PCE of order 4 give the same moments of the LST with
    uncertain mu, l_f and mean wind: both converge to the exact moments, so they agree to 0.2 %
    of each state's largest std (measured ~1e-4)."""
    cp = pytest.importorskip("chaospy")
    germs = cp.J(cp.Normal(0, 1), cp.Normal(0, 1), cp.Uniform(-1, 1))
    nodes, weights = cp.generate_quadrature(5, germs, rule="gaussian")
    unc = config["uncertainty"]
    draws = {
        "mu": unc["mu"]["mean"] + unc["mu"]["std"] * nodes[0],
        "l_f": unc["l_f"]["mean"] + unc["l_f"]["std"] * nodes[1],
        "F_w_mean": 0.5 * (unc["F_w_mean"]["low"] + unc["F_w_mean"]["high"] + nodes[2] * (unc["F_w_mean"]["high"] - unc["F_w_mean"]["low"])),
    }
    y = lst_response(Settings.from_config(config), draws)  # (4, Q, T)
    expansion = cp.generate_expansion(4, germs, normed=True)
    T = y.shape[-1]
    evals = y.transpose(1, 0, 2).reshape(y.shape[1], -1)
    approx = cp.fit_quadrature(expansion, nodes, weights, evals)
    mean_cp = cp.E(approx, germs).reshape(4, T)
    std_cp = cp.Std(approx, germs).reshape(4, T)
    model = LSTChaosModel(Settings.from_config(config), uncertain=("mu", "l_f", "F_w_mean"), time_variant_wind=False, order=4, quadrature_points=5)
    r = model.moments(Settings.from_config(config).uncertainty.theta(model.uncertain))
    scale = std_cp.max(axis=1, keepdims=True)
    assert np.abs(r.mean - mean_cp).max() < 2e-3 * scale.max()
    assert np.all(np.abs(r.std - std_cp) < 2e-3 * scale)


def test_first_order_sobol_against_salib(config):
    """First-order indices of y(5 s) and beta(2 s) from the PCE lie inside SALib's Saltelli
    estimate +- its 95 % confidence half-width (times 1.5, so three outputs by three
    parameters do not fail by chance; the seed is fixed)."""
    pytest.importorskip("SALib")
    from SALib.analyze import sobol as sobol_analyze
    from SALib.sample import sobol as sobol_sample

    unc = config["uncertainty"]
    problem = {
        "num_vars": 3,
        "names": ["mu", "l_f", "F_w_mean"],
        "bounds": [[unc["mu"]["mean"], unc["mu"]["std"]], [unc["l_f"]["mean"], unc["l_f"]["std"]], [unc["F_w_mean"]["low"], unc["F_w_mean"]["high"]]],
        "dists": ["norm", "norm", "unif"],
    }
    X = sobol_sample.sample(problem, 2048, calc_second_order=False, seed=7)
    y = lst_response(Settings.from_config(config), {"mu": X[:, 0], "l_f": X[:, 1], "F_w_mean": X[:, 2]})
    model = LSTChaosModel(Settings.from_config(config), uncertain=("mu", "l_f", "F_w_mean"), time_variant_wind=False, order=3)
    r = model.moments(Settings.from_config(config).uncertainty.theta(model.uncertain))
    names, S1 = model.sobol(r)
    dt = config["time"]["dt"]
    for state, t in ((3, 5.0), (2, 2.0), (1, 7.5)):
        k = int(round(t / dt))
        res = sobol_analyze.analyze(problem, y[state, :, k], calc_second_order=False, seed=7)
        assert np.all(np.abs(S1[:, state, k] - res["S1"]) <= 1.5 * res["S1_conf"] + 1e-3), (state, S1[:, state, k], res["S1"], res["S1_conf"])


def test_sobol_groups_sum_below_one(config, full_model):
    r = full_model.moments(Settings.from_config(config).uncertainty.theta(full_model.uncertain))
    names, S1 = full_model.sobol(r)
    _, ST = full_model.sobol(r, total=True)
    assert names == ["mu", "m_load", "l_f", "F_w_mean", "wind (time-variant)"]
    k = slice(10, None)
    assert np.all(S1[:, :, k].sum(axis=0) <= 1 + 1e-12) and np.all(ST[:, :, k] >= S1[:, :, k] - 1e-12)


@pytest.mark.parametrize(
    "theta, message",
    [
        ([1.0, -0.2, 1.55, 0.2, -400, 400], "standard deviation of mu must be positive"),
        ([1.0, 0.2, 1.55, 0.0, -400, 400], "standard deviation of l_f"),
        ([1.0, 0.2, 1.55, 0.2, 400, 400], "degenerate"),
        ([1.0, 0.2], "must have 6 entries"),
    ],
)
def test_bad_parameters_are_named(ident_model, theta, message):
    with pytest.raises(ValueError, match=message):
        ident_model.moments(np.array(theta, float))


def test_unknown_uncertain_parameter(config):
    with pytest.raises(ValueError, match="unknown uncertain parameter"):
        LSTChaosModel(Settings.from_config(config), uncertain=("mu", "tyre_pressure"))


def test_adjoint_gradient_equals_forward_sensitivities(config):
    """moments_vjp (one backward recursion + one adjoint Frechet derivative) gives the same
    gradient of a random linear functional of the mean and variance as the forward
    sensitivities, to 1e-10 relative (round-off of two exact derivatives)."""
    from uqdrive.vehicle.chaos import LSTChaosModel

    model = LSTChaosModel(Settings.from_config(config), uncertain=("mu", "l_f", "F_w_mean"), time_variant_wind=False)
    theta = np.array([0.9, 0.25, 1.5, 0.15, -300.0, 500.0])
    rng = np.random.default_rng(0)
    w_mean, w_var = rng.normal(size=(2, 4, model.time.size))
    full = model.moments(theta, gradient=True)
    forward = np.einsum("pit,it->p", full.mean_gradient, w_mean) + np.einsum("pit,it->p", full.variance_gradient, w_var)
    result, vjp = model.moments_vjp(theta)
    # expm and expm_frechet's own exponential round differently: ~1e-12 absolute on the mean
    assert result.mean == pytest.approx(full.mean, rel=1e-8, abs=1e-11)
    assert vjp(w_mean, w_var) == pytest.approx(forward, rel=1e-10)


def test_moments_are_those_of_the_coefficients(config, full_model):
    """Mean and variance read from the block-ordered states equal (4.51) on the full coefficient
    array (zero for never-excited terms), to round-off."""
    r = full_model.moments(Settings.from_config(config).uncertainty.theta(full_model.uncertain))
    c = r.coefficients
    assert c.shape == (4, full_model.projector.n_terms, full_model.time.size)
    assert r.mean == pytest.approx(c[:, 0], rel=1e-14, abs=0.0)
    assert r.variance == pytest.approx((c[:, 1:] ** 2).sum(axis=1), rel=1e-13, abs=1e-300)
    assert not np.any(c[:, ~full_model.projector.excited])


def test_input_only_wind_germ_equals_the_parametric_treatment(ident_model):
    """The mean wind's germ as a linear germ (exact products, its order >= 2 terms dropped)
    gives the thesis' treatment, the germ integrated by 4 Gauss-Legendre points like the
    others, to round-off (1e-10 relative): the quadrature is exact for that germ's degree 5."""
    from dataclasses import replace

    from uqdrive.numerics.galerkin import GalerkinProjector
    from uqdrive.numerics.integrate import foh_discretise_single, lti_response_single
    from uqdrive.vehicle.single_track import lst_matrices

    theta = np.array([0.9, 0.25, 1.5, 0.18, -300.0, 450.0])
    r = ident_model.moments(theta)
    pr = GalerkinProjector(["normal", "normal", "uniform"], 0, 2, quadrature_points=4)
    xi = pr.nodes
    p = replace(ident_model.vehicle, mu=theta[0] + theta[1] * xi[:, 0], m_load=np.full(xi.shape[0], 110.0), l_f=theta[2] + theta[3] * xi[:, 1])
    A, B, W = lst_matrices(p)
    wind = 0.5 * (theta[4] + theta[5] + xi[:, 2] * (theta[5] - theta[4]))
    maps = foh_discretise_single(pr.matrix(A), pr.input_matrix(np.stack([B, W * wind[:, None]], axis=-1)), ident_model.dt)
    c = pr.coefficients(lti_response_single(*maps, ident_model.inputs[:, :2], np.zeros(4 * pr.n_terms)))
    assert r.mean == pytest.approx(c[:, :, 0].T, rel=1e-10, abs=1e-12 * np.abs(r.mean).max())
    assert r.variance == pytest.approx((c[:, :, 1:] ** 2).sum(axis=-1).T, rel=1e-10, abs=1e-12 * r.variance.max())
    assert ident_model.projector.nodes.shape[0] == 16 and pr.nodes.shape[0] == 64

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import approx_fprime

from uqdrive.wheelslip.gp import ArcsineGP, arcsine_kernel, arcsine_kernel_grad_x, arcsine_kernel_grad_xx

X = np.linspace(-0.3, 1.1, 9)
G = np.array([0.4, 7.0])


def test_kernel_equals_gpy_mlp_form():
    """FACTS: GPy's MLP kernel variance (2/pi) asin((s_w^2 x y + s_b^2) / sqrt((s_w^2 x^2 + s_b^2 + 1)
    (s_w^2 y^2 + s_b^2 + 1))) with s_b^2 = 2 g0, s_w^2 = 2 g1, variance = (pi/2) v1."""
    v1 = 1.7
    sb2, sw2, var = 2 * G[0], 2 * G[1], np.pi / 2 * v1
    x, y = X[:, None], X[None, :]
    gpy = var * 2 / np.pi * np.arcsin((sw2 * x * y + sb2) / np.sqrt((sw2 * x**2 + sb2 + 1) * (sw2 * y**2 + sb2 + 1)))
    assert arcsine_kernel(X, X, v1, G) == pytest.approx(gpy, rel=1e-13)


@pytest.mark.parametrize("h", [1e-6])
def test_kernel_derivatives_against_central_differences(h):
    Y = X[::-1] + 0.05
    fd1 = (arcsine_kernel(X + h, Y, 1.3, G) - arcsine_kernel(X - h, Y, 1.3, G)) / (2 * h)
    assert arcsine_kernel_grad_x(X, Y, 1.3, G) == pytest.approx(fd1, rel=1e-7, abs=1e-9)
    fd2 = (arcsine_kernel_grad_x(X, Y + h, 1.3, G) - arcsine_kernel_grad_x(X, Y - h, 1.3, G)) / (2 * h)
    assert arcsine_kernel_grad_xx(X, Y, 1.3, G) == pytest.approx(fd2, rel=1e-6, abs=1e-8)


def test_two_input_derivatives():
    rng = np.random.default_rng(0)
    A, B = rng.normal(size=(4, 2)), rng.normal(size=(3, 2))
    g = np.array([0.5, 2.0, 0.7])
    h = 1e-6
    e = np.array([0.0, h])
    fd = (arcsine_kernel_grad_x(A, B + e, 1.0, g, j=0) - arcsine_kernel_grad_x(A, B - e, 1.0, g, j=0)) / (2 * h)
    assert arcsine_kernel_grad_xx(A, B, 1.0, g, j=0, i=1) == pytest.approx(fd, rel=1e-6, abs=1e-8)


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 10_000), n=st.integers(2, 15))
def test_kernel_matrices_are_positive_semidefinite(seed, n):
    rng = np.random.default_rng(seed)
    x = rng.uniform(-2, 2, n)
    g = np.exp(rng.uniform(-3, 3, 2))
    for K in (arcsine_kernel(x, x, 1.0, g), arcsine_kernel_grad_xx(x, x, 1.0, g)):
        assert np.linalg.eigvalsh(0.5 * (K + K.T)).min() > -1e-9 * np.abs(K).max()


def test_marginal_likelihood_gradient():
    rng = np.random.default_rng(2)
    x = np.linspace(0, 1, 10)
    gp = ArcsineGP(restarts=1).fit(x, np.tanh(4 * x) + 0.05 * rng.normal(size=10))
    theta = np.array([0.2, -1.0, 1.5, -4.0])
    fd = approx_fprime(theta, lambda t: gp._nll_and_grad(t)[0], 1e-7)
    assert gp._nll_and_grad(theta)[1] == pytest.approx(fd, rel=1e-5, abs=1e-5)


def test_slope_prediction_of_smooth_function():
    x = np.linspace(0, 1, 25)
    gp = ArcsineGP(restarts=3, rng=np.random.default_rng(0)).fit(x, np.tanh(3 * x))
    m, v = gp.predict_slope(np.array([0.5]))
    true = 3 / np.cosh(1.5) ** 2
    assert abs(m[0] - true) < 0.05 and v[0] >= 0.0


def test_noise_does_not_enter_the_slope_variance():
    """var = d2k(x*, x*) - d1k(x*, X) (K + v0 I)^-1 d1k(X, x*): v0 appears only in the data
    covariance, never as a term of its own (the slope is of the latent function)."""
    x = np.array([0.0, 0.05, 0.1])
    y = np.array([0.0, 0.8, 0.9])
    hyper = {"v1": 1.0, "g": [0.5, 30.0], "v0": 0.01}
    gp = ArcsineGP(hyperparameters=hyper).fit(x, y)
    xs = np.array([0.15])
    k_s = arcsine_kernel_grad_x(xs, x, 1.0, hyper["g"])
    K = arcsine_kernel(x, x, 1.0, hyper["g"]) + 0.01 * np.eye(3)
    expected = arcsine_kernel_grad_xx(xs, xs, 1.0, hyper["g"])[0, 0] - (k_s @ np.linalg.solve(K, k_s.T))[0, 0]
    assert gp.predict_slope(xs)[1][0] == pytest.approx(expected, rel=1e-8)
    assert gp.predict_slope(xs)[0][0] == pytest.approx((k_s @ np.linalg.solve(K, y))[0], rel=1e-8)


def test_noise_free_point_is_interpolated():
    x = np.array([0.0, 0.05, 0.1, 0.2])
    y = np.array([0.0, 0.9, 0.8, 1.0])
    gp = ArcsineGP(restarts=2, rng=np.random.default_rng(0)).fit(x, y, noise_free=[True, False, False, False])
    m, v = gp.predict(np.array([0.0]))
    assert abs(m[0]) < 1e-4 and v[0] < 1e-6


def test_bad_data_is_rejected():
    with pytest.raises(ValueError, match="finite"):
        ArcsineGP().fit([0.0, 1.0], [0.0, np.nan])

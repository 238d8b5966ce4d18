"""Gaussian-process regression with the arcsine (neural-network) covariance of the GP paper, eq. (6),
and predictions of the function and of its slope, each with mean and variance.

No maintained Python library predicts the slope variance for this kernel (FACTS), so the kernel,
its input derivatives and the marginal likelihood are small NumPy/SciPy functions here.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import cho_factor, cho_solve, solve_triangular
from scipy.optimize import minimize

from ..numerics.threads import with_single_blas_thread

__all__ = [
    "arcsine_kernel",
    "arcsine_kernel_grad_x",
    "arcsine_kernel_grad_xx",
    "ArcsineGP",
]


def _augment(X):
    X = np.asarray(X, float)
    X = X[:, None] if X.ndim == 1 else X
    return np.hstack([np.ones((X.shape[0], 1)), X])  # x~ = (1, x): the bias input


def _parts(X1, X2, g):
    """u = 2 x~1' G x~2, a = 1 + 2 x~1' G x~1, b = 1 + 2 x~2' G x~2 and z = u / sqrt(a b)."""
    A, B = _augment(X1), _augment(X2)
    g = np.asarray(g, float)
    u = 2.0 * (A * g) @ B.T
    a = 1.0 + 2.0 * np.sum(A * A * g, axis=1)
    b = 1.0 + 2.0 * np.sum(B * B * g, axis=1)
    root = np.sqrt(np.outer(a, b))
    return A, B, u, a, b, root, u / root


def arcsine_kernel(X1, X2, v1: float, g):
    """Williams' arcsine covariance, paper eq. (6) corrected (FACTS), without the noise term.

    k(x, x') = v1 asin( 2 x~' G x~' / sqrt((1 + 2 x~' G x~)(1 + 2 x~'' G x~')) ), x~ = (1, x).

    Parameters
    ----------
    X1 : ndarray, shape (n1,) or (n1, D)
    X2 : ndarray, shape (n2,) or (n2, D)
    v1 : float
        Signal scale.
    g : ndarray, shape (D + 1,)
        Diagonal of G: bias weight g0, then one weight per input.

    Returns
    -------
    ndarray, shape (n1, n2)
    """
    *_, z = _parts(X1, X2, g)
    return v1 * np.arcsin(np.clip(z, -1.0, 1.0))


def _dz_dx1(A, B, a, root, z, g, j):
    """d z / d x1_j (input j, i.e. column j + 1 of the augmented inputs)."""
    m = j + 1
    return 2.0 * g[m] * B[None, :, m] / root - z * 2.0 * g[m] * A[:, None, m] / a[:, None]


def _dz_dx2(A, B, b, root, z, g, i):
    m = i + 1
    return 2.0 * g[m] * A[:, None, m] / root - z * 2.0 * g[m] * B[None, :, m] / b[None, :]


def arcsine_kernel_grad_x(X1, X2, v1: float, g, j: int = 0):
    """d k(x1, x2) / d x1_j: the covariance of the slope at x1 with the function at x2 (paper 7).

    Returns
    -------
    ndarray, shape (n1, n2)
    """
    g = np.asarray(g, float)
    A, B, u, a, b, root, z = _parts(X1, X2, g)
    return v1 * _dz_dx1(A, B, a, root, z, g, j) / np.sqrt(1.0 - z**2)


def arcsine_kernel_grad_xx(X1, X2, v1: float, g, j: int = 0, i: int = 0):
    """d^2 k(x1, x2) / d x1_j d x2_i: the covariance of two slopes (paper eq. 8).

    Returns
    -------
    ndarray, shape (n1, n2)
    """
    g = np.asarray(g, float)
    A, B, u, a, b, root, z = _parts(X1, X2, g)
    dz1 = _dz_dx1(A, B, a, root, z, g, j)
    dz2 = _dz_dx2(A, B, b, root, z, g, i)
    mj, mi = j + 1, i + 1
    d2z = (
        2.0 * g[mj] * (mj == mi) / root
        - (2.0 * g[mj] * B[None, :, mj]) * (2.0 * g[mi] * B[None, :, mi]) / (b[None, :] * root)
        - (2.0 * g[mj] * A[:, None, mj] / a[:, None]) * dz2
    )
    s = 1.0 - z**2
    return v1 * (z * dz1 * dz2 / s**1.5 + d2z / np.sqrt(s))


class ArcsineGP:
    """GP regression with the arcsine covariance; hyperparameters by maximum marginal likelihood.

    Parameters
    ----------
    restarts : int
        Random restarts of the L-BFGS-B search on log hyperparameters [log v1, log g, log v0].
    rng : numpy.random.Generator, optional
        Source of the restart points (seeded by the caller for reproducibility).
    bounds : (float, float)
        Bounds on every log hyperparameter, keeping the search inside a sane box.
    hyperparameters : dict, optional
        Fixed {"v1", "g", "v0"}: skip the optimisation (e.g. the exact calibration test).

    Attributes
    ----------
    v1_, g_, v0_ : fitted hyperparameters
    log_marginal_likelihood_ : float
    """

    def __init__(self, restarts: int = 5, rng: np.random.Generator | None = None, bounds=(-9.0, 9.0), hyperparameters=None):
        self.restarts = int(restarts)
        self.rng = rng if rng is not None else np.random.default_rng(0)
        self.bounds = bounds
        self.hyperparameters = hyperparameters

    # -- marginal likelihood ----------------------------------------------------------------
    def _unpack(self, log_theta, D):
        theta = np.exp(log_theta)
        return theta[0], theta[1 : D + 2], theta[D + 2]

    def _factor(self, log_theta):
        """Cholesky factor of the training covariance K at ``log_theta`` (None where K is not
        numerically positive definite), the hyperparameters and the kernel parts the gradient
        needs: (factor, (v1, g, v0), (A, a, b, root, z))."""
        v1, g, v0 = self._unpack(log_theta, self._X.shape[1])
        A, _, u, a, b, root, z = _parts(self._X, self._X, g)
        z = np.clip(z, -1 + 1e-15, 1 - 1e-15)
        try:
            c = cho_factor(v1 * np.arcsin(z) + np.diag(v0 * self._noisy + self._jitter), lower=True)
        except np.linalg.LinAlgError:
            c = None
        return c, (v1, g, v0), (A, a, b, root, z)

    def _nll_of_factor(self, c):
        """NLL and alpha = K^-1 y from the Cholesky factor of K."""
        y = self._y
        alpha = cho_solve(c, y)
        return 0.5 * y @ alpha + np.sum(np.log(np.diag(c[0]))) + 0.5 * y.size * np.log(2 * np.pi), alpha

    def _nll(self, log_theta) -> float:
        """Negative log marginal likelihood alone (no gradient): what a sampler needs, at a
        third of the cost of :meth:`_nll_and_grad` (one Cholesky factor, no inverse)."""
        c = self._factor(log_theta)[0]
        return 1e25 if c is None else self._nll_of_factor(c)[0]

    def _nll_batch(self, log_thetas) -> np.ndarray:
        """:meth:`_nll` at many points at once, for a sampler that moves a whole ensemble.

        Parameters
        ----------
        log_thetas : ndarray, shape (W, D + 3)
            Log hyperparameters [log v1, log g_0..g_D, log v0] per row.

        Returns
        -------
        ndarray, shape (W,)
            The NLL per row (1e25 where the covariance is not numerically positive definite).
        """
        X, y, noisy = self._X, self._y, self._noisy
        lt = np.atleast_2d(np.asarray(log_thetas, float))
        theta = np.exp(lt)
        v1, g, v0 = theta[:, 0], theta[:, 1:-1], theta[:, -1]
        A = _augment(X)
        u = 2.0 * np.einsum("id,wd,jd->wij", A, g, A)
        root = np.sqrt(1.0 + 2.0 * np.einsum("id,wd->wi", A * A, g))  # sqrt(a) per point
        z = np.clip(u / (root[:, :, None] * root[:, None, :]), -1 + 1e-15, 1 - 1e-15)
        K = v1[:, None, None] * np.arcsin(z)
        K[:, np.arange(y.size), np.arange(y.size)] += v0[:, None] * noisy + self._jitter
        try:
            L = np.linalg.cholesky(K)
        except np.linalg.LinAlgError:  # one bad row fails the stack: those rows alone, one by one
            return np.array([self._nll(row) for row in lt])
        quad = np.einsum("i,wi->w", y, np.linalg.solve(K, y[None, :, None])[..., 0])
        logdet = np.sum(np.log(np.diagonal(L, axis1=1, axis2=2)), axis=1)
        return 0.5 * quad + logdet + 0.5 * y.size * np.log(2 * np.pi)

    def _nll_and_grad(self, log_theta):
        y, noisy, D = self._y, self._noisy, self._X.shape[1]
        c, (v1, g, v0), (A, a, b, root, z) = self._factor(log_theta)
        if c is None:
            return 1e25, np.zeros_like(log_theta)
        nll, alpha = self._nll_of_factor(c)
        W = np.outer(alpha, alpha) - cho_solve(c, np.eye(y.size))  # d nll = -1/2 tr(W dK)
        grads = [v1 * np.arcsin(z)]  # d K / d log v1
        ds = v1 / np.sqrt(1.0 - z**2)
        for m in range(D + 1):
            dz = 2.0 * np.outer(A[:, m], A[:, m]) / root - z * (A[:, m, None] ** 2 / a[:, None] + A[None, :, m] ** 2 / b[None, :])
            grads.append(ds * dz * g[m])  # chain rule for log g_m
        grads.append(np.diag(v0 * noisy))
        grad = np.array([-0.5 * np.sum(W * dK) for dK in grads])
        return nll, grad

    # tens-by-tens Cholesky factors: OpenBLAS threads make them several times slower (threads.py)
    @with_single_blas_thread
    def fit(self, X, y, noise_free=None) -> "ArcsineGP":
        """Fit to observations y at X; ``noise_free`` marks exact points (e.g. mu(0) = 0).

        Parameters
        ----------
        X : ndarray, shape (n,) or (n, D)
        y : ndarray, shape (n,)
        noise_free : ndarray of bool, shape (n,), optional
        """
        X = np.asarray(X, float)
        self._X = X[:, None] if X.ndim == 1 else X
        self._y = np.asarray(y, float)
        n, D = self._X.shape
        if self._y.shape != (n,) or not np.all(np.isfinite(self._y)) or not np.all(np.isfinite(self._X)):
            raise ValueError("X and y must be finite and y must have one value per row of X")
        self._noisy = np.ones(n) if noise_free is None else (~np.asarray(noise_free, bool)).astype(float)
        self._jitter = 1e-10
        if self.hyperparameters is not None:
            h = self.hyperparameters
            log_theta = np.log(np.concatenate([[h["v1"]], np.asarray(h["g"], float), [h["v0"]]]))
        else:
            lo, hi = self.bounds
            best = None
            starts = [np.zeros(D + 3)] + [self.rng.uniform(-3, 3, D + 3) for _ in range(max(self.restarts - 1, 0))]
            for x0 in starts:
                res = minimize(self._nll_and_grad, x0, jac=True, method="L-BFGS-B", bounds=[(lo, hi)] * (D + 3))
                if np.isfinite(res.fun) and (best is None or res.fun < best.fun):
                    best = res
            log_theta = best.x
        self.log_theta_ = log_theta
        self.v1_, self.g_, self.v0_ = self._unpack(log_theta, D)
        self.log_marginal_likelihood_ = -self._nll(log_theta)
        K = arcsine_kernel(self._X, self._X, self.v1_, self.g_) + np.diag(self.v0_ * self._noisy + self._jitter)
        self._L = np.linalg.cholesky(K)
        self._alpha = cho_solve((self._L, True), self._y)
        return self

    # -- predictions --------------------------------------------------------------------------
    def _posterior(self, k_star, k_star_star):
        mean = k_star @ self._alpha
        v = solve_triangular(self._L, k_star.T, lower=True)
        return mean, k_star_star - np.sum(v * v, axis=0)

    def predict(self, X):
        """Mean and variance of the latent function f at X (without the noise v0), eqs. (4)-(5)."""
        k_star = arcsine_kernel(X, self._X, self.v1_, self.g_)
        k_ss = np.diag(arcsine_kernel(X, X, self.v1_, self.g_))
        return self._posterior(k_star, k_ss)

    def predict_slope(self, X, j: int = 0):
        """Mean and variance of the slope df/dx_j at X, from covariances (7)-(8).

        The noise term v0 delta(x, x') has no input derivative, so it does not enter the slope
        variance. The variance returned is the variance of the slope, not the slope of the
        variance.
        """
        k_star = arcsine_kernel_grad_x(X, self._X, self.v1_, self.g_, j)
        k_ss = np.diag(arcsine_kernel_grad_xx(X, X, self.v1_, self.g_, j, j))
        return self._posterior(k_star, k_ss)

    def predict_joint(self, X):
        """Joint posterior of f at X (mean (m,), covariance (m, m)), for drawing curves."""
        k_star = arcsine_kernel(X, self._X, self.v1_, self.g_)
        mean = k_star @ self._alpha
        v = solve_triangular(self._L, k_star.T, lower=True)
        return mean, arcsine_kernel(X, X, self.v1_, self.g_) - v.T @ v

"""Gaussian-process regression with the arcsine (neural-network) covariance of the GP paper, eq. (6),
and predictions of the function and of its slope, each with mean and variance.

No maintained Python library predicts the slope variance for this kernel (FACTS), so the kernel,
its input derivatives and the marginal likelihood are small NumPy/SciPy functions here.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import solve_triangular
from scipy.linalg.lapack import dpotrf, dpotrs, dtrtri
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
    """u = 2 x~1' G x~2, a = 1 + 2 x~1' G x~1, b = 1 + 2 x~2' G x~2 and z = u / sqrt(a b); a stack
    of g, shape (..., D + 1), gives a stack of each, (..., n1) and (..., n1, n2)."""
    A, B = _augment(X1), _augment(X2)
    g = np.asarray(g, float)[..., None, :]  # broadcasts over the points
    u = 2.0 * (A * g) @ B.T
    a = 1.0 + 2.0 * np.sum(A * A * g, axis=-1)
    b = 1.0 + 2.0 * np.sum(B * B * g, axis=-1)
    root = np.sqrt(a[..., :, None] * b[..., None, :])
    return A, B, u, a, b, root, u / root


def _w(weights, m):
    """Weight m of g (shape (D + 1,) or (..., D + 1)), shaped to scale (..., n1, n2) arrays."""
    return weights[..., m, None, None]


def arcsine_kernel(X1, X2, v1: float, g):
    """Williams' arcsine covariance, paper eq. (6) corrected (FACTS), without the noise term.

    k(x, x') = v1 asin( 2 x~' G x~' / sqrt((1 + 2 x~' G x~)(1 + 2 x~'' G x~')) ), x~ = (1, x).

    Parameters
    ----------
    X1, X2 : ndarray, shape (n1,) or (n1, D), and (n2,) or (n2, D)
        Inputs in their own units (here the wheel slip, (-)).
    v1 : float or ndarray, shape (...)
        Signal scale, in the output's unit squared (friction coefficient: (-)).
    g : ndarray, shape (D + 1,) or (..., D + 1)
        Diagonal of G (-, per input unit squared): bias weight g0, then one weight per input; a stack of them (with v1 of
        the stack's shape) gives a stack of covariances.

    Returns
    -------
    ndarray, shape (n1, n2) or (..., n1, n2)
    """
    *_, z = _parts(X1, X2, g)
    return np.asarray(v1, float)[..., None, None] * np.arcsin(np.clip(z, -1.0, 1.0))


def _dz_dx1(A, B, a, root, z, g, j):
    """d z / d x1_j (input j, i.e. column j + 1 of the augmented inputs)."""
    m = j + 1
    return 2.0 * _w(g, m) * B[None, :, m] / root - z * 2.0 * _w(g, m) * A[:, None, m] / a[..., :, None]


def _dz_dx2(A, B, b, root, z, g, i):
    m = i + 1
    return 2.0 * _w(g, m) * A[:, None, m] / root - z * 2.0 * _w(g, m) * B[None, :, m] / b[..., None, :]


def arcsine_kernel_grad_x(X1, X2, v1: float, g, j: int = 0):
    """d k(x1, x2) / d x1_j: the covariance of the slope at x1 with the function at x2 (paper 7).

    Parameters and stacks as :func:`arcsine_kernel`.

    Returns
    -------
    ndarray, shape (n1, n2) or (..., n1, n2)
    """
    g = np.asarray(g, float)
    A, B, u, a, b, root, z = _parts(X1, X2, g)
    return np.asarray(v1, float)[..., None, None] * _dz_dx1(A, B, a, root, z, g, j) / np.sqrt(1.0 - z**2)


def arcsine_kernel_grad_xx(X1, X2, v1: float, g, j: int = 0, i: int = 0):
    """d^2 k(x1, x2) / d x1_j d x2_i: the covariance of two slopes (paper eq. 8).

    Parameters and stacks as :func:`arcsine_kernel`.

    Returns
    -------
    ndarray, shape (n1, n2) or (..., n1, n2)
    """
    g = np.asarray(g, float)
    A, B, u, a, b, root, z = _parts(X1, X2, g)
    dz1 = _dz_dx1(A, B, a, root, z, g, j)
    dz2 = _dz_dx2(A, B, b, root, z, g, i)
    mj, mi = j + 1, i + 1
    d2z = (
        2.0 * _w(g, mj) * (mj == mi) / root
        - (2.0 * _w(g, mj) * B[None, :, mj]) * (2.0 * _w(g, mi) * B[None, :, mi]) / (b[..., None, :] * root)
        - (2.0 * _w(g, mj) * A[:, None, mj] / a[..., :, None]) * dz2
    )
    s = 1.0 - z**2
    return np.asarray(v1, float)[..., None, None] * (z * dz1 * dz2 / s**1.5 + d2z / np.sqrt(s))


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

    def _covariance(self, log_theta):
        """Training covariance at log hyperparameters, with the parts the gradient needs.

        The arithmetic is that of :func:`arcsine_kernel` (u, a, sqrt(a a'), z), step for step, for
        one point or a stack of them alike.

        Parameters
        ----------
        log_theta : ndarray, shape (..., D + 3)

        Returns
        -------
        K : ndarray, shape (..., n, n)
            v1 asin(z) plus v0 on the noisy points and the jitter on the diagonal.
        S : ndarray, shape (..., n, n)
            asin(z).
        z : ndarray, shape (..., n, n)
            Clipped to |z| <= 1 - 1e-15 (never active for data of order 1: tools/mutate.py).
        B : ndarray, shape (..., n, D + 1)
            The scaled inputs x~ / sqrt(a) of the gradient.
        """
        theta = np.exp(log_theta)[..., None, :]  # (..., 1, D + 3): broadcasts over the points
        v1, g, v0 = theta[..., :1], theta[..., 1:-1], theta[..., 0, -1:]
        A = self._A
        AAg = A * A * g
        a = AAg[..., 0]
        for m in range(1, A.shape[1]):  # np.sum(AAg, axis=-1) term by term: same sum, no reduction set-up
            a = a + AAg[..., m]
        a = 1.0 + 2.0 * a
        # in place where possible: every fresh n x n temporary costs an allocation and a cache pass
        z = (2.0 * A * g) @ A.T  # u (the factor 2 is exact, wherever it is applied)
        root = np.multiply(a[..., :, None], a[..., None, :])
        z /= np.sqrt(root, out=root)
        z = np.clip(z, -1 + 1e-15, 1 - 1e-15)
        S = np.arcsin(z)
        K = np.multiply(v1, S, out=root)
        diag = np.arange(A.shape[0])
        K[..., diag, diag] += v0 * self._noisy + self._jitter
        return K, S, z, A / np.sqrt(a)[..., None]

    def _factor(self, K):
        """NLL, lower Cholesky factor L (upper triangle zero) and alpha = K^-1 y of one training
        covariance, or None where K is not numerically positive definite.

        LAPACK's potrf/potrs directly, as scipy's cho_factor/cho_solve call them, without their
        input checks (K is finite by construction: |z| < 1, theta = exp(bounded)).

        Parameters
        ----------
        K : ndarray, shape (n, n)
        """
        # K's lower triangle, as cho_factor(K, lower=True) reads it (u is symmetric to rounding only)
        L, info = dpotrf(K, lower=1, clean=1)
        if info != 0:
            return None
        alpha = dpotrs(L, self._y, lower=1)[0]
        return 0.5 * self._y @ alpha + np.log(L.diagonal()).sum() + self._log_2pi_term, L, alpha

    def _nll(self, log_theta) -> float:
        """Negative log marginal likelihood alone (no gradient): what a sampler needs, without the
        inverse of :meth:`_nll_and_grad`."""
        f = self._factor(self._covariance(np.asarray(log_theta, float))[0])
        return 1e25 if f is None else f[0]

    def negative_log_likelihood(self, log_thetas) -> np.ndarray:
        """:meth:`_nll` at many points at once, for a sampler that moves a whole ensemble (emcee's
        vectorised form): the same arithmetic per row, so each row equals :meth:`_nll` exactly.

        Parameters
        ----------
        log_thetas : ndarray, shape (W, D + 3)
            Log hyperparameters [log v1, log g_0..g_D, log v0] per row (logs of unit-free values).

        Returns
        -------
        ndarray, shape (W,)
            The NLL per row (1e25 where the covariance is not numerically positive definite).
        """
        return np.array([1e25 if f is None else f[0] for f in self._row_factors(log_thetas)])

    def _nll_and_grad(self, log_theta):
        """NLL and its gradient in the log hyperparameters, d nll = -1/2 tr(W dK) with
        W = alpha alpha' - K^-1 (Rasmussen & Williams 5.9).

        The traces need no dK: with Wd = W / sqrt(1 - z^2) and C = Wd B, the g_m component is
        -v1 g_m (sum_i B_im C_im - sum_i B_im^2 sum_j Wd_ij z_ij), from dK/dg_m = v1 dz/dg_m / sqrt(1 - z^2)
        and dz/dg_m = 2 B_m B_m' - z (B_m^2 1' + 1 B_m^2') (W symmetric); the v1 component is
        -v1 <W, asin z> / 2 and the v0 component -v0 sum(diag(W) noisy) / 2. Five n x n passes and
        two products with B instead of a dK and a product with W per hyperparameter.
        """
        K, S, z, B = self._covariance(np.asarray(log_theta, float))
        f = self._factor(K)
        if f is None:
            return 1e25, np.zeros_like(log_theta)
        nll, L, alpha = f
        v1, g, v0 = self._unpack(log_theta, self._X.shape[1])
        Linv = dtrtri(L, lower=1)[0]
        W = np.outer(alpha, alpha)
        W -= Linv.T @ Linv  # K^-1 from the factor's inverse: a third of potrs against the identity
        Wd = W / np.sqrt(1.0 - z * z)
        C = Wd @ B
        rz = np.einsum("ij,ij->i", Wd, z)
        grad_g = -v1 * g * (np.einsum("im,im->m", B, C) - (B * B).T @ rz)
        return nll, np.concatenate([[-0.5 * v1 * np.vdot(W, S)], grad_g, [-0.5 * v0 * (np.diag(W) @ self._noisy)]])

    def _row_factors(self, log_thetas):
        """:meth:`_factor` of each row's covariance, the covariances built in stacks of at most
        ~16k entries: a stack that leaves the cache costs more than the Python calls it saves
        (n = 101, 6 rows: 1.0 ms stacked against 0.7 ms one by one)."""
        rows = np.atleast_2d(np.asarray(log_thetas, float))
        chunk = max(1, 16384 // self._y.size**2)
        for i in range(0, len(rows), chunk):
            yield from map(self._factor, self._covariance(rows[i : i + chunk])[0])

    @with_single_blas_thread
    def slope_posteriors(self, log_thetas, x, j: int = 0):
        """Mean and variance of the slope df/dx_j at one input x under each row of hyperparameters:
        :meth:`predict_slope` of a GP fitted to this GP's data with that row's fixed hyperparameters,
        with the same arithmetic, but without fitting one GP per row (the emcee mixture's draws).

        Parameters
        ----------
        log_thetas : ndarray, shape (R, D + 3)
            Log hyperparameters [log v1, log g_0..g_D, log v0] per row (logs of unit-free values).
        x : float or ndarray, shape (D,)
            Input at which the slope is taken (wheel slip, (-)).
        j : int
            Input of the slope.

        Returns
        -------
        mean, variance : ndarray, shape (R,)
        """
        rows = np.atleast_2d(np.asarray(log_thetas, float))
        theta = np.exp(rows)
        xs = np.atleast_2d(np.asarray(x, float))
        k_star = arcsine_kernel_grad_x(xs, self._X, theta[:, 0], theta[:, 1:-1], j)  # (R, 1, n)
        k_ss = arcsine_kernel_grad_xx(xs, xs, theta[:, 0], theta[:, 1:-1], j, j)[:, 0, 0]
        mean, variance = np.empty(len(rows)), np.empty(len(rows))
        for r, f in enumerate(self._row_factors(rows)):
            if f is None:
                raise np.linalg.LinAlgError("the training covariance is not positive definite")
            mean[r], variance[r] = (a[0] for a in self._posterior(k_star[r], k_ss[r : r + 1], f[1], f[2]))
        return mean, variance

    # tens-by-tens Cholesky factors: OpenBLAS threads make them several times slower (threads.py)
    @with_single_blas_thread
    def fit(self, X, y, noise_free=None) -> "ArcsineGP":
        """Fit to observations y at X; ``noise_free`` marks exact points (e.g. mu(0) = 0).

        Parameters
        ----------
        X : ndarray, shape (n,) or (n, D)
            Inputs (wheel slip, (-)).
        y : ndarray, shape (n,)
            Observations (friction coefficient, (-)).
        noise_free : ndarray of bool, shape (n,), optional
        """
        X = np.asarray(X, float)
        self._X = X[:, None] if X.ndim == 1 else X
        self._y = np.asarray(y, float)
        n, D = self._X.shape
        if self._y.shape != (n,) or not np.all(np.isfinite(self._y)) or not np.all(np.isfinite(self._X)):
            raise ValueError("X and y must be finite and y must have one value per row of X")
        self._A = _augment(self._X)
        self._noisy = np.ones(n) if noise_free is None else (~np.asarray(noise_free, bool)).astype(float)
        self._jitter = 1e-10
        self._log_2pi_term = 0.5 * n * np.log(2 * np.pi)
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
        f = self._factor(self._covariance(log_theta)[0])
        if f is None:
            raise np.linalg.LinAlgError("the training covariance is not positive definite")
        nll, self._L, self._alpha = f  # the predictions' factor is the likelihood's
        self.log_marginal_likelihood_ = -nll
        return self

    # -- predictions --------------------------------------------------------------------------
    def _posterior(self, k_star, k_star_star, L=None, alpha=None):
        """Posterior mean and variance from cross- and prior covariances, with this GP's factor and
        alpha = K^-1 y or given ones (L: lower Cholesky factor of K)."""
        L, alpha = (self._L, self._alpha) if L is None else (L, alpha)
        mean = k_star @ alpha
        v = solve_triangular(L, k_star.T, lower=True)
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

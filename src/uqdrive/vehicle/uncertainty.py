"""Uncertain parameters as maps from standard germs (thesis 5.8-5.11) and the Karhunen-Loeve
expansion of the coloured side-wind process by the Nystrom method (thesis 5.16-5.22).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..settings import PARAMETER_NAMES, Uncertainty, Wind

__all__ = [
    "PARAMETER_NAMES",
    "ParameterDistribution",
    "normal_from_germ",
    "uniform_germ",
    "uniform_from_germ",
    "germ_from_uniform",
    "squared_exponential_covariance",
    "KarhunenLoeve",
    "kle_nystrom",
    "kle_of_wind",
    "Germs",
]

def normal_from_germ(xi, mean, std):
    """Normal parameter from a standard normal germ, mean + std * xi, thesis (5.8)-(5.10)."""
    return mean + std * np.asarray(xi, dtype=float)


# The uniform germ's one convention, for every ensemble (ParameterDistribution, Germs): xi ~ U(-1, 1),
# drawn by uniform_germ, mapped by uniform_from_germ, read back by germ_from_uniform.
def uniform_germ(rng: np.random.Generator, size) -> np.ndarray:
    """Germs xi ~ U(-1, 1) of the given ``size`` (shape) from ``rng``, thesis (5.11)."""
    return rng.uniform(-1.0, 1.0, size=size)


def uniform_from_germ(xi, low, high):
    """Uniform parameter from a germ xi ~ U(-1, 1), thesis (5.11): (high + low + xi (high - low)) / 2."""
    return 0.5 * (high + low + np.asarray(xi, dtype=float) * (high - low))


def germ_from_uniform(value, low, high):
    """The germ xi in [-1, 1] of a uniform parameter's ``value`` in [low, high] (low < high),
    the inverse of :func:`uniform_from_germ`: (2 value - high - low) / (high - low)."""
    return (2.0 * np.asarray(value, dtype=float) - high - low) / (high - low)


@dataclass(frozen=True)
class ParameterDistribution:
    """Distributions of mu, m_load, l_f (normal: mean, std) and the mean wind (uniform: low, high).

    ``germs`` arrays have shape (n, 4): columns are standard normal for mu, m_load, l_f and
    U(-1, 1) for the mean wind, in the order of :data:`PARAMETER_NAMES`.
    """

    mu: tuple[float, float] = (1.0, 0.2)
    m_load: tuple[float, float] = (100.0, 30.0)
    l_f: tuple[float, float] = (1.55, 0.2)
    F_w_mean: tuple[float, float] = (-400.0, 400.0)

    @classmethod
    def from_settings(cls, u: Uncertainty) -> "ParameterDistribution":
        """The distributions of the settings' uncertain quantities."""
        return cls(mu=u.mu.theta, m_load=u.m_load.theta, l_f=u.l_f.theta, F_w_mean=u.F_w_mean.theta)

    @staticmethod
    def sample_germs(rng: np.random.Generator, n: int) -> np.ndarray:
        """Draw n germ vectors, shape (n, 4): three N(0, 1) columns, then one U(-1, 1)."""
        normal = rng.standard_normal((n, 3))
        uniform = uniform_germ(rng, (n, 1))
        return np.hstack([normal, uniform])

    def from_germs(self, germs) -> dict[str, np.ndarray]:
        """Map germs of shape (..., 4) to parameter values, (5.8)-(5.11)."""
        germs = np.asarray(germs, dtype=float)
        return {
            "mu": normal_from_germ(germs[..., 0], *self.mu),
            "m_load": normal_from_germ(germs[..., 1], *self.m_load),
            "l_f": normal_from_germ(germs[..., 2], *self.l_f),
            "F_w_mean": uniform_from_germ(germs[..., 3], *self.F_w_mean),
        }


def squared_exponential_covariance(t1, t2, Tc: float):
    """Covariance of the unit wind process, thesis (5.2): exp(-(t1 - t2)^2 / Tc^2).

    Parameters
    ----------
    t1, t2 : ndarray, shape (n1,) and (n2,)
        Times (s).
    Tc : float
        Correlation time constant (s).

    Returns
    -------
    ndarray, shape (n1, n2)
    """
    d = np.subtract.outer(np.asarray(t1, float), np.asarray(t2, float))
    return np.exp(-(d**2) / Tc**2)


@dataclass(frozen=True)
class KarhunenLoeve:
    """Truncated KLE of a zero-mean unit-variance process, thesis (4.58) and (5.20)-(5.21).

    Attributes
    ----------
    nodes, weights : ndarray, shape (n_q,)
        Gauss-Legendre points (s) and weights (s) on the interval.
    eigenvalues : ndarray, shape (n_c,)
        Retained eigenvalues lambda_n (s), descending.
    nodal_functions : ndarray, shape (n_c, n_q)
        Eigenfunctions at the nodes, normalised so that sum_k w_k f_n(t_k)^2 = 1 (4.60).
    all_eigenvalues : ndarray, shape (n_q,)
        Every Nystrom eigenvalue, for the truncation report (5.22).
    Tc : float
        Covariance time constant (s).
    """

    nodes: np.ndarray
    weights: np.ndarray
    eigenvalues: np.ndarray
    nodal_functions: np.ndarray
    all_eigenvalues: np.ndarray
    Tc: float

    @property
    def n_modes(self) -> int:
        """Number of KLE modes kept."""
        return int(self.eigenvalues.size)

    @property
    def captured_variance(self) -> float:
        """Retained share of the total eigenvalue sum, the left side of (5.22) over the right."""
        return float(self.eigenvalues.sum() / self.all_eigenvalues.sum())

    def eigenfunctions(self, t) -> np.ndarray:
        """Nystrom interpolation of the eigenfunctions, thesis (5.20).

        Parameters
        ----------
        t : array_like, shape (m,)
            Times (s) inside the expansion interval.

        Returns
        -------
        ndarray, shape (n_c, m)
        """
        C = squared_exponential_covariance(self.nodes, t, self.Tc)
        return (self.nodal_functions * self.weights) @ C / self.eigenvalues[:, None]

    def realise(self, xi, t) -> np.ndarray:
        """Realisations sum_n sqrt(lambda_n) xi_n f_n(t), thesis (5.21).

        Parameters
        ----------
        xi : ndarray, shape (n, n_c)
            Standard normal germs.
        t : array_like, shape (m,)

        Returns
        -------
        ndarray, shape (n, m)
        """
        return (np.asarray(xi) * np.sqrt(self.eigenvalues)) @ self.eigenfunctions(t)


def kle_nystrom(t_start: float, t_end: float, Tc: float, n_quadrature: int, truncation: float) -> KarhunenLoeve:
    """KLE of the squared-exponential process by Nystrom's method, thesis (5.16)-(5.22).

    The generalised eigenproblem C W f = lambda f (5.18) is solved in its symmetric form
    (W^1/2 C W^1/2) v = lambda v with f = W^-1/2 v, which is exact algebra and keeps the
    eigenvectors orthonormal under the quadrature inner product.

    Parameters
    ----------
    t_start, t_end : float
        Expansion interval (s).
    Tc : float
        Covariance time constant (s).
    n_quadrature : int
        Number of Gauss-Legendre points N_GLQ,KLE.
    truncation : float
        p_c in (0, 1]: keep the fewest eigenpairs whose eigenvalue sum reaches p_c of the total.

    Returns
    -------
    KarhunenLoeve
    """
    x, w = np.polynomial.legendre.leggauss(n_quadrature)
    half = 0.5 * (t_end - t_start)
    nodes = t_start + half * (x + 1.0)  # (5.15)
    weights = half * w
    sqrt_w = np.sqrt(weights)
    C = squared_exponential_covariance(nodes, nodes, Tc)
    lam, V = np.linalg.eigh(sqrt_w[:, None] * C * sqrt_w[None, :])
    lam, V = lam[::-1], V[:, ::-1]
    lam = np.clip(lam, 0.0, None)  # round-off makes the tail slightly negative
    cumulative = np.cumsum(lam)
    n_keep = int(np.searchsorted(cumulative, truncation * cumulative[-1] * (1 - 1e-12)) + 1)
    functions = (V[:, :n_keep] / sqrt_w[:, None]).T
    # Fix the sign so results do not depend on the LAPACK build: f_n(t_start-side node) >= 0.
    functions *= np.where(functions[:, :1] < 0, -1.0, 1.0)
    return KarhunenLoeve(nodes, weights, lam[:n_keep].copy(), functions, lam, float(Tc))


def kle_of_wind(wind: Wind, t_end: float) -> KarhunenLoeve:
    """The KLE (5.16)-(5.22) of the unit side wind over [0, ``t_end``] (s) with the settings
    ``wind`` (Tc, Gauss-Legendre points, truncation)."""
    return kle_nystrom(0.0, t_end, wind.Tc, wind.kle_quadrature, wind.kle_truncation)


@dataclass(frozen=True)
class Germs:
    """Standard germs of n realisations: normal for mu, l_f, m_load, U(-1, 1) for the mean wind
    (:func:`uniform_germ`, as every ensemble), normal (n, n_c) for the KLE gust modes."""

    mu: np.ndarray
    l_f: np.ndarray
    m_load: np.ndarray
    wind: np.ndarray
    kle: np.ndarray

    @classmethod
    def draw(cls, rng: np.random.Generator, n: int, n_modes: int, matched: bool = False) -> "Germs":
        """n realisations' germs from ``rng``; ``matched``: moment-matched (:meth:`matched`)."""
        z = rng.standard_normal((3, n))
        germs = cls(z[0], z[1], z[2], uniform_germ(rng, n), rng.standard_normal((n, n_modes)))
        return germs.matched() if matched else germs

    def matched(self) -> "Germs":
        """Moment matching (a variance reduction for common random numbers): the germ vector
        (mu, l_f, m_load, the wind's germ standardised as sqrt(3) xi, the KLE modes) is
        shifted and jointly whitened (Cholesky) so that its sample mean is exactly 0 and its
        sample covariance exactly I, the population's moments.

        A model ensemble on matched germs reproduces every statistic that is linear or quadratic
        in the germs without sampling error: the mean wind's and the gusts' share of the mean and
        variance, and their cross terms with mu, l_f and the load. Unmatched, an ensemble of M
        realisations misstates e.g. a gust mode's variance by ~sqrt(2 / M) (4.5 % at M = 1000),
        an error that no distribution parameter can absorb (a gust scale moves all modes alike).
        The wind's germ keeps its uniform shape up to an O(M^-1/2) affine change (it may leave
        [-1, 1] by that much). Needs n > 4 + n_modes.
        """
        z = np.column_stack([self.mu, self.l_f, self.m_load, np.sqrt(3.0) * self.wind, self.kle])
        if z.shape[0] <= z.shape[1]:
            raise ValueError(f"moment matching of {z.shape[1]} germs needs more than {z.shape[1]} realisations; got {z.shape[0]}")
        z = z - z.mean(axis=0)
        L = np.linalg.cholesky(np.cov(z, rowvar=False))
        w = np.linalg.solve(L, z.T).T
        return Germs(w[:, 0], w[:, 1], w[:, 2], w[:, 3] / np.sqrt(3.0), np.ascontiguousarray(w[:, 4:]))

    @property
    def n(self) -> int:
        """Number of realisations."""
        return int(self.mu.size)

    def head(self, n: int) -> "Germs":
        """The first ``n`` realisations' germs."""
        return Germs(self.mu[:n], self.l_f[:n], self.m_load[:n], self.wind[:n], self.kle[:n])

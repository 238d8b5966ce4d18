"""Orthonormal polynomial families of the Wiener-Askey scheme (thesis Table 4.2), total-order
multi-indices (4.21)-(4.22) and tensor Gauss quadrature for any number of germs.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import combinations_with_replacement
from math import comb
from typing import Callable

import numpy as np
from numpy.polynomial import hermite_e, legendre

__all__ = ["PolynomialFamily", "FAMILIES", "family", "multi_indices", "n_terms", "tensor_quadrature"]


@dataclass(frozen=True)
class PolynomialFamily:
    """An orthonormal family for one standard germ.

    Attributes
    ----------
    name : str
        Family name ("hermite", "legendre").
    distribution : str
        Distribution of the germ it is orthonormal for ("normal": N(0, 1), "uniform": U(-1, 1)).
    recurrence : callable
        ``recurrence(n) -> (a, b)`` of the monic-free three-term recurrence
        P_{n+1} = (x P_n - b_n P_{n-1}) / a_{n+1} of the orthonormal polynomials.
    rule : callable
        ``rule(n) -> (nodes, weights)`` of the n-point Gauss rule, weights summing to one.
    """

    name: str
    distribution: str
    recurrence: Callable[[int], float]
    rule: Callable[[int], tuple]

    def evaluate(self, x, degree: int) -> np.ndarray:
        """Values of the orthonormal polynomials of degree 0..``degree`` at ``x``.

        Parameters
        ----------
        x : array_like, shape (...)
        degree : int

        Returns
        -------
        ndarray, shape (..., degree + 1)
        """
        if degree < 0:
            raise ValueError(f"polynomial degree must be non-negative, got {degree}")
        x = np.asarray(x, dtype=float)
        out = np.empty(x.shape + (degree + 1,))
        out[..., 0] = 1.0
        if degree >= 1:
            out[..., 1] = x / self.recurrence(1)
        for n in range(1, degree):
            out[..., n + 1] = (x * out[..., n] - self.recurrence(n) * out[..., n - 1]) / self.recurrence(n + 1)
        return out

    def quadrature(self, n_points: int) -> tuple[np.ndarray, np.ndarray]:
        """n-point Gauss rule for the germ's density: exact for polynomials of degree <= 2n - 1."""
        if n_points < 1:
            raise ValueError(f"quadrature needs at least one point, got {n_points}")
        return self.rule(n_points)


def _hermite_rule(n):
    x, w = hermite_e.hermegauss(n)
    return x, w / np.sqrt(2.0 * np.pi)


def _legendre_rule(n):
    x, w = legendre.leggauss(n)
    return x, w / 2.0


# Orthonormal three-term recurrences x p_n = a_{n+1} p_{n+1} + b_n p_{n-1} (b_n = a_n):
# Hermite (probabilists'): He_n / sqrt(n!), a_n = sqrt(n); Legendre on U(-1, 1):
# sqrt(2n + 1) P_n, a_n = n / sqrt(4 n^2 - 1).
HERMITE = PolynomialFamily("hermite", "normal", lambda n: np.sqrt(n), _hermite_rule)
LEGENDRE = PolynomialFamily("legendre", "uniform", lambda n: n / np.sqrt(4.0 * n * n - 1.0), _legendre_rule)

#: Registry: a distribution or family name selects the family (config strings use these).
FAMILIES = {"normal": HERMITE, "gaussian": HERMITE, "hermite": HERMITE, "uniform": LEGENDRE, "legendre": LEGENDRE}


def family(name: str) -> PolynomialFamily:
    """Look a family up by distribution or family name; a clear error names the choices."""
    try:
        return FAMILIES[name.lower()]
    except (KeyError, AttributeError):
        raise ValueError(
            f"unsupported germ distribution '{name}'; supported: {', '.join(sorted(FAMILIES))}"
        ) from None


def n_terms(n_germs: int, order: int) -> int:
    """Number of total-order terms, thesis (4.22): (N_p + N_PCE)! / (N_p! N_PCE!)."""
    return comb(n_germs + order, order)


def multi_indices(n_germs: int, order: int) -> np.ndarray:
    """Total-order multi-indices in graded order, thesis (4.21) and Table 4.4.

    Within one total degree the indices are sorted so that earlier germs carry the higher
    powers first, which reproduces Table 4.4: [0 0], [1 0], [0 1], [2 0], [1 1], [0 2], ...

    Returns
    -------
    ndarray of int, shape (n_terms, n_germs)
    """
    if order < 0:
        raise ValueError(f"PCE order must be non-negative, got {order}")
    if n_germs < 1:
        raise ValueError(f"need at least one germ, got {n_germs}")
    rows = []
    for degree in range(order + 1):
        for combo in combinations_with_replacement(range(n_germs), degree):
            alpha = np.zeros(n_germs, dtype=int)
            for g in combo:
                alpha[g] += 1
            rows.append(alpha)
    return np.array(rows, dtype=int).reshape(-1, n_germs)


def tensor_quadrature(families, n_points) -> tuple[np.ndarray, np.ndarray]:
    """Tensor product of one-dimensional Gauss rules.

    Parameters
    ----------
    families : sequence of PolynomialFamily
    n_points : int or sequence of int
        Points per germ.

    Returns
    -------
    nodes : ndarray, shape (Q, n_germs)
    weights : ndarray, shape (Q,), summing to one
    """
    if np.isscalar(n_points):
        n_points = [int(n_points)] * len(families)
    rules = [f.quadrature(n) for f, n in zip(families, n_points)]
    grids = np.meshgrid(*[r[0] for r in rules], indexing="ij")
    nodes = np.stack([g.ravel() for g in grids], axis=-1)
    weights = np.ones(1)
    for _, w in rules:
        weights = np.multiply.outer(weights, w).ravel()
    return nodes, weights


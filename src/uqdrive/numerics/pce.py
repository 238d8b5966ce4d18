"""A polynomial chaos basis over several germs: projection by quadrature, moments (thesis 4.51)
and Sobol indices from the coefficients (thesis 4.76-4.77), vectorised over any trailing shape.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from .polynomials import family, multi_indices, tensor_quadrature

__all__ = ["PolynomialChaos"]


class PolynomialChaos:
    """Orthonormal total-order chaos basis phi_k(xi) = prod_j P_{alpha_kj}(xi_j), thesis (4.20).

    Parameters
    ----------
    distributions : sequence of str
        One germ distribution per germ ("normal" or "uniform", see ``polynomials.FAMILIES``).
    order : int
        Total polynomial order N_PCE.
    quadrature_points : int or sequence of int, optional
        Gauss points per germ for projections (default order + 1: the projection of a
        polynomial of degree up to order + 1 onto the basis is then exact).

    Attributes
    ----------
    indices : ndarray of int, shape (P, n_germs)
        Multi-indices, graded as thesis Table 4.4.
    nodes : ndarray, shape (Q, n_germs)
    weights : ndarray, shape (Q,)
    basis_at_nodes : ndarray, shape (Q, P)
    """

    def __init__(self, distributions: Sequence[str], order: int, quadrature_points=None):
        self.families = [family(d) for d in distributions]
        self.order = int(order)
        self.indices = multi_indices(len(self.families), self.order)
        q = self.order + 1 if quadrature_points is None else quadrature_points
        self.nodes, self.weights = tensor_quadrature(self.families, q)
        self.basis_at_nodes = self.evaluate_basis(self.nodes)

    @property
    def n_germs(self) -> int:
        """Number of germs (random input variables)."""
        return len(self.families)

    @property
    def n_terms(self) -> int:
        """Number of basis terms P (total-order multi-indices)."""
        return self.indices.shape[0]

    def evaluate_basis(self, xi) -> np.ndarray:
        """phi_k(xi) for every term.

        Parameters
        ----------
        xi : array_like, shape (..., n_germs)

        Returns
        -------
        ndarray, shape (..., P)
        """
        xi = np.asarray(xi, float)
        out = np.ones(xi.shape[:-1] + (self.n_terms,))
        for j, fam in enumerate(self.families):
            values = fam.evaluate(xi[..., j], self.order)  # (..., order + 1)
            out *= values[..., self.indices[:, j]]
        return out

    def project(self, values_at_nodes) -> np.ndarray:
        """Coefficients X_k = <f, phi_k> by the tensor quadrature (orthonormal basis, F = I).

        Parameters
        ----------
        values_at_nodes : ndarray, shape (Q, ...)
            f evaluated at ``nodes``.

        Returns
        -------
        ndarray, shape (P, ...)
        """
        f = np.asarray(values_at_nodes, float)
        return np.tensordot(self.basis_at_nodes * self.weights[:, None], f, axes=(0, 0))

    def evaluate(self, coefficients, xi) -> np.ndarray:
        """The expansion sum_k X_k phi_k(xi); coefficients (P, ...) and xi (m, n_germs) -> (m, ...)."""
        return np.tensordot(self.evaluate_basis(xi), np.asarray(coefficients), axes=(-1, 0))

    @staticmethod
    def mean(coefficients) -> np.ndarray:
        """Mean X_0, thesis (4.26) with an orthonormal basis; coefficients (P, ...)."""
        return np.asarray(coefficients)[0]

    @staticmethod
    def variance(coefficients) -> np.ndarray:
        """Variance sum_{k >= 1} X_k^2, thesis (4.32)/(4.51b); coefficients (P, ...)."""
        c = np.asarray(coefficients)
        return np.sum(c[1:] ** 2, axis=0)

    def sobol(self, coefficients, groups=None, total: bool = False) -> np.ndarray:
        """First-order (4.76) or total (4.77) Sobol indices of germ groups, in one pass.

        Parameters
        ----------
        coefficients : ndarray, shape (P, ...)
        groups : sequence of sequence of int, optional
            Germ groups (default: each germ alone). A group's first-order index sums the
            terms whose non-zero powers all lie in the group (e.g. all KLE germs of the wind
            together, as in thesis Fig. 5.4); its total index sums the terms that touch it.
        total : bool
            Total instead of first-order indices.

        Returns
        -------
        ndarray, shape (n_groups, ...)
            NaN where the variance is zero.
        """
        c2 = np.asarray(coefficients) ** 2
        var = c2[1:].sum(axis=0)
        groups = [[j] for j in range(self.n_germs)] if groups is None else [list(g) for g in groups]
        active = self.indices > 0  # (P, n_germs)
        selectors = []
        for g in groups:
            inside = active[:, g].any(axis=1)
            if not total:
                outside = np.delete(active, g, axis=1).any(axis=1)
                inside &= ~outside
            selectors.append(inside)
        S = np.array(selectors, dtype=float)  # (n_groups, P)
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.tensordot(S, c2, axes=(1, 0)) / np.where(var > 0, var, np.nan)

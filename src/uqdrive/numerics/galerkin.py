"""Galerkin projection of a stochastic LTI system onto a polynomial chaos (thesis 4.39-4.49):
precomputed quadrature tensors, so re-assembly for new parameters is a few contractions.

The system is x' = A(xi_p) x + E(xi_p) g(t) + sum_j F_j(xi_p) xi_j h_j(t), x(0) = x0(xi_p):
the matrices depend on the parametric germs xi_p (integrated by tensor Gauss quadrature), and
the linear germs xi_j (e.g. the KLE germs of the wind) enter the input linearly, so their inner
products are exact and analytic: <phi_k xi_j> = 1 if alpha_k = e_j on the linear germs, else 0.
"""

from __future__ import annotations

import functools
from typing import Sequence

import numpy as np

from .pce import PolynomialChaos
from .polynomials import family, tensor_quadrature

__all__ = ["GalerkinProjector"]


class GalerkinProjector:
    """Galerkin tensors of a chaos over parametric germs (quadrature) and linear Gaussian germs.

    Parameters
    ----------
    parametric : sequence of str
        Distributions of the germs the matrices depend on ("normal", "uniform").
    n_linear : int or sequence of str
        The germs that enter linearly (input or initial state): a count of standard normal
        germs, or their distributions ("normal", "uniform").
    order : int
        Total order N_PCE of the chaos over all germs (4.21).
    quadrature_points : int
        Gauss points per parametric germ (the thesis uses 4).

    Attributes
    ----------
    chaos : PolynomialChaos
        The basis over [parametric..., linear...] germs, for moments and Sobol indices.
    nodes : ndarray, shape (Q, n_parametric)
        Quadrature nodes in the parametric germs, where the caller evaluates A, E, F, x0.
    G_par : ndarray, shape (P_par, P_par, Q)
        w_q psi_a(xi_q) psi_b(xi_q) over the distinct parametric parts a, b of the terms; the
        full tensor G[k, l, q] = G_par[par[k], par[l], q] [linear parts of k and l equal] is never
        formed (for 9 germs at order 4 it would take 5 GB).
    par : ndarray of int, shape (P,)
        Parametric part of each term, as a row of ``G_par``.
    same_linear : ndarray of bool, shape (P, P)
    g0 : ndarray, shape (P, Q)
        w_q phi_k(xi_q) for terms without linear germs (zero otherwise).
    g_lin : ndarray, shape (n_linear, P, Q)
        w_q phi_k(xi_q) for the terms whose linear part is xi_j alone.
    """

    def __init__(self, parametric: Sequence[str], n_linear, order: int, quadrature_points: int = 4):
        if quadrature_points < 1:
            raise ValueError(f"quadrature_points must be positive, got {quadrature_points}")
        if isinstance(n_linear, (int, np.integer)):
            if n_linear < 0:
                raise ValueError(f"n_linear must be non-negative, got {n_linear}")
            linear = ["normal"] * int(n_linear)
        else:
            linear = list(n_linear)
        n_linear = len(linear)
        parametric = list(parametric)
        n_par = len(parametric)
        self.chaos = PolynomialChaos(parametric + linear, order, quadrature_points=1)
        # xi_j = c_j P_1(xi_j) with the orthonormal degree-1 polynomial: c = 1 (Hermite), 1/sqrt(3) (Legendre).
        self.linear_scale = np.array([1.0 / family(d).evaluate(np.array([1.0]), 1)[0, 1] for d in linear])
        families = [family(d) for d in parametric]
        self.nodes, self.weights = tensor_quadrature(families, quadrature_points)
        alpha = self.chaos.indices
        alpha_par, alpha_lin = alpha[:, :n_par], alpha[:, n_par:]
        unique_par, self.par = np.unique(alpha_par, axis=0, return_inverse=True)
        self.par = self.par.ravel()
        psi_par = np.ones((self.nodes.shape[0], unique_par.shape[0]))
        for j, fam in enumerate(families):
            psi_par *= fam.evaluate(self.nodes[:, j], order)[:, unique_par[:, j]]
        self.G_par = np.einsum("qa,qb->abq", self.weights[:, None] * psi_par, psi_par)
        self.same_linear = (alpha_lin[:, None, :] == alpha_lin[None, :, :]).all(axis=-1)
        psi = psi_par[:, self.par]  # (Q, P)
        wpsi = self.weights[:, None] * psi
        self.g0 = wpsi.T * (alpha_lin.sum(axis=1) == 0)[:, None]
        unit = np.eye(n_linear, dtype=int)
        self.g_lin = (
            np.stack([self.linear_scale[j] * wpsi.T * (alpha_lin == unit[j]).all(axis=1)[:, None] for j in range(n_linear)])
            if n_linear
            else np.zeros((0,) + wpsi.T.shape)
        )
        self.n_parametric, self.n_linear = n_par, n_linear
        self._G_flat = self.G_par.reshape(-1, self.G_par.shape[-1])  # (Pp Pp, Q)
        self._n_par_terms = unique_par.shape[0]

    @property
    def n_terms(self) -> int:
        """Number of PCE basis terms P."""
        return self.chaos.n_terms

    @property
    def excited(self) -> np.ndarray:
        """Terms that can be non-zero: at most first order in the linear germs.

        A, E and x0 do not depend on the linear germs and they enter linearly, so the blocks of
        terms with a linear part of order >= 2 start at zero and receive no input: dropping their
        states is exact and shrinks e.g. 78 terms to 50 for 4 + 7 germs at order 2.
        """
        return self.chaos.indices[:, self.n_parametric :].sum(axis=1) <= 1

    @staticmethod
    def scatter(reduced, mask) -> np.ndarray:
        """Put states (..., mask.sum()) of the reduced system back into (..., mask.size), zeros
        elsewhere (the input itself, not a copy, when every state is kept)."""
        if mask.all():
            return np.asarray(reduced)
        full = np.zeros(np.shape(reduced)[:-1] + (mask.size,))
        full[..., mask] = reduced
        return full

    def state_mask(self, d: int) -> np.ndarray:
        """Mask of the expanded states (d P,) that belong to excited terms (state-major layout)."""
        return np.tile(self.excited, d)

    def block_order(self, d: int) -> np.ndarray:
        """The excited expanded states (indices into the state-major d P layout), block by block.

        First the terms without linear germs, then for each linear germ j the terms whose linear
        part is xi_j; state-major inside each block. A does not depend on the linear germs, so
        these blocks never couple: in this order the expanded A is block diagonal with
        consecutive blocks, and the recursion advances them by slices (the KLE germs' blocks,
        which are identical, as one batch).

        Returns
        -------
        ndarray of int, shape (N,)
        """
        P = self.n_terms
        alpha_lin = self.chaos.indices[:, self.n_parametric :]
        block = (alpha_lin > 0).argmax(axis=1) + 1 if self.n_linear else np.zeros(P, int)
        block[alpha_lin.sum(axis=1) == 0] = 0
        excited = self.excited
        return np.array(
            [i * P + k for b in range(self.n_linear + 1) for i in range(d) for k in np.flatnonzero(excited & (block == b))],
            int,
        )

    # Layout: the expanded state X is the (d, P) coefficient array flattened state-major,
    # X[i * P + k] = X_ik, as thesis (4.40). ``states`` selects and orders rows (and columns)
    # of that layout, e.g. ``block_order``; the selection is a gather from the small products
    # of the quadrature tensors with the node values, so no full d P x d P matrix is formed.
    def matrix(self, values, states=None) -> np.ndarray:
        """A_PCE = <Phi A Phi^T>, thesis (4.44a) (and (4.48) for a stochastic input).

        Parameters
        ----------
        values : ndarray, shape (..., Q, d, d)
            A(xi_q) at the nodes; leading axes (e.g. parameter derivatives) are kept.
        states : ndarray of int, shape (N,), optional
            Rows and columns to return, in the state-major d P layout (all by default).

        Returns
        -------
        ndarray, shape (..., N, N)
        """
        v = np.asarray(values, float)
        d = v.shape[-1]
        index, mask = self._matrix_gather(d, self._states_key(states))
        small = self._G_flat @ v.reshape(v.shape[:-2] + (d * d,))  # (..., Pp Pp, d d)
        return np.take(small.reshape(v.shape[:-3] + (small.shape[-2] * d * d,)), index, axis=-1) * mask

    def input_matrix(self, values, states=None) -> np.ndarray:
        """E_PCE = <Phi E>, thesis (4.44b), for inputs g(t) shared by all realisations.

        Parameters
        ----------
        values : ndarray, shape (..., Q, d, r)
        states : ndarray of int, shape (N,), optional
            Rows to return (all d P by default).

        Returns
        -------
        ndarray, shape (..., N, r)
        """
        v = np.asarray(values, float)
        d, r = v.shape[-2], v.shape[-1]
        rows = self._term_major_rows(d, self._states_key(states))
        out = self.g0 @ v.reshape(v.shape[:-2] + (d * r,))  # (..., P, d r)
        return np.take(out.reshape(v.shape[:-3] + (self.n_terms * d, r)), rows, axis=-2)

    def linear_input_matrix(self, values, states=None) -> np.ndarray:
        """<Phi F_j xi_j> for the linear germs: column j multiplies the signal h_j(t).

        Parameters
        ----------
        values : ndarray, shape (..., Q, d, n_linear)
            F_j(xi_q) at the nodes.
        states : ndarray of int, shape (N,), optional
            Rows to return (all d P by default).

        Returns
        -------
        ndarray, shape (..., N, n_linear)
        """
        v = np.asarray(values, float)
        d = v.shape[-2]
        rows = self._term_major_rows(d, self._states_key(states))
        out = self.g_lin @ np.moveaxis(v, -1, -3)  # (..., n_linear, P, d)
        out = np.take(out.reshape(out.shape[:-2] + (self.n_terms * d,)), rows, axis=-1)  # (..., n_linear, N)
        return np.swapaxes(out, -1, -2)

    @staticmethod
    def _states_key(states):
        """A hashable form of a state selection, for the cached gathers (None: all states)."""
        return None if states is None else np.asarray(states, int).tobytes()

    def _states(self, d, key):
        return np.arange(d * self.n_terms) if key is None else np.frombuffer(key, int)

    @functools.lru_cache(maxsize=16)
    def _matrix_gather(self, d, key):
        """Flat indices into the (Pp, Pp, d, d) products and the same-linear-part mask, (N, N)."""
        states = self._states(d, key)
        i, k = np.divmod(states, self.n_terms)
        a = self.par[k]
        Pp = self._n_par_terms
        index = ((a[:, None] * Pp + a[None, :]) * d + i[:, None]) * d + i[None, :]
        return index, self.same_linear[np.ix_(k, k)].astype(float)

    @functools.lru_cache(maxsize=16)
    def _term_major_rows(self, d, key):
        """Row k d + i of a (P, d) term-major array for each selected state i P + k."""
        i, k = np.divmod(self._states(d, key), self.n_terms)
        return k * d + i

    def linear_initial_state(self, values) -> np.ndarray:
        """X(0) part of an initial state linear in the linear germs, x0 = sum_j x0_j(xi_p) xi_j.

        values : ndarray, shape (Q, d, n_linear) -> (d P,)
        """
        return self.linear_input_matrix(values).sum(axis=-1)

    def initial_state(self, values) -> np.ndarray:
        """X(0) = <Phi x0>, thesis (4.44c); values (..., Q, d) -> (..., d P)."""
        v = np.asarray(values, float)
        d, P = v.shape[-1], self.n_terms
        return np.einsum("kq,...qi->...ik", self.g0, v, optimize=True).reshape(v.shape[:-2] + (d * P,))

    def coefficients(self, X) -> np.ndarray:
        """Reshape expanded states (..., d P) to coefficients (..., d, P)."""
        X = np.asarray(X)
        return X.reshape(X.shape[:-1] + (-1, self.n_terms))

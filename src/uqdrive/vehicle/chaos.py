"""The stochastic linear single-track model (5.4) as a Galerkin PCE (thesis sec. 5.2): distribution
parameters -> mean and variance trajectories of every state, with exact gradients.

This is the model interface the identification uses: ``moments(theta, gradient=...)``.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, replace
from typing import Mapping, Sequence

import numpy as np

from ..numerics.adjoint import foh_response_vjp
from ..numerics.batched_lti import foh_discretise_batched, lti_response_batched
from ..numerics.galerkin import GalerkinProjector
from ..numerics.integrate import foh_discretise_single, lti_response_single
from ..settings import Settings
from .montecarlo import STEERS
from ..numerics.threads import with_single_blas_thread
from .single_track import VehicleParameters, gust_input_column, lst_matrices, lst_matrices_at_speed, steering_input
from .uncertainty import kle_of_wind

__all__ = ["DISTRIBUTIONS", "BatchMoments", "ChaosMoments", "LSTChaosModel"]

#: Distribution of each uncertain parameter, thesis (5.8)-(5.11).
DISTRIBUTIONS = {"mu": "normal", "m_load": "normal", "l_f": "normal", "F_w_mean": "uniform"}
#: Parameters that enter the LST only through its input, linearly (E = [B, W F_w]): their germs
#: are linear germs of the projector, integrated exactly, not by quadrature.
INPUT_ONLY = ("F_w_mean",)
_STEP = 1e-30  # complex step: derivatives exact to round-off


@dataclass(frozen=True)
class ChaosMoments:
    """Moments of the expanded LST on the output grid.

    Attributes
    ----------
    time : ndarray, shape (T,)
    mean, variance : ndarray, shape (4, T)
        Per state (psi, psi_dot, beta, y), thesis (4.51).
    mean_gradient, variance_gradient : ndarray, shape (n_theta, 4, T) or None
    states : ndarray, shape (T, N)
        The expanded states as computed (excited terms only, in ``state_index`` order).
    state_index : ndarray of int, shape (N,)
        Position of each computed state in the state-major (4, P) coefficient layout.
    n_terms : int
        P.
    """

    time: np.ndarray
    mean: np.ndarray
    variance: np.ndarray
    mean_gradient: np.ndarray | None
    variance_gradient: np.ndarray | None
    states: np.ndarray
    state_index: np.ndarray
    n_terms: int

    @property
    def std(self) -> np.ndarray:
        """Standard deviation, shape (4, T), in each state's unit (negative round-off variance -> 0)."""
        return np.sqrt(np.maximum(self.variance, 0.0))

    @functools.cached_property
    def coefficients(self) -> np.ndarray:
        """PCE coefficients (4, P, T) of every state (zero for the never-excited terms)."""
        full = np.zeros((self.states.shape[0], 4 * self.n_terms))
        full[:, self.state_index] = self.states
        return full.reshape(-1, 4, self.n_terms).transpose(1, 2, 0)


@dataclass(frozen=True)
class BatchMoments:
    """Moments of the expanded LST at B parameter vectors (:meth:`LSTChaosModel.moments_batch`):
    time (T,); mean, variance (B, 4, T), NaN where ``admissible`` (B,) is False, i.e. where
    ``moments`` raises ValueError (a std <= 0, low >= high, a quadrature node not physical)."""

    time: np.ndarray
    mean: np.ndarray
    variance: np.ndarray
    admissible: np.ndarray


class LSTChaosModel:
    """Galerkin PCE of the LST with uncertain mu, m_load, l_f, mean wind and the KLE wind.

    Parameters
    ----------
    settings : Settings
        The car, its uncertainty (for the fixed values), the wind, steering and time grid.
    uncertain : sequence of str
        Uncertain parameters among ``DISTRIBUTIONS``; the others are fixed.
    time_variant_wind : bool
        Include the KLE wind germs (linear germs of the projector).
    order : int
        N_PCE.
    quadrature_points : int
        Gauss points per parametric germ (N_GLQ,PCE).
    steer : {"normal", "inverted"}
    fixed : mapping, optional
        Values of fixed parameters (default: the means; the mean wind's midpoint).
        A quantity declared known (``std: 0``, ``low == high``,
        :meth:`uqdrive.settings.Uncertainty.known`) is fixed at its value whether or
        not ``uncertain`` names it: it has no germ and no entries in ``theta``.
    delta : ndarray, shape (T,), optional
        Measured steering angle on the output grid (rad); overrides (5.5)/(5.7) and ``steer``.

    Attributes
    ----------
    expanded_states : ndarray of int, shape (N,)
        The computed (excited) expanded states, in the projector's block order.
    mean_rows : ndarray of int, shape (4,)
        Row of each state's constant term among ``expanded_states``: its mean.
    variance_indicator : ndarray, shape (N, 4)
        1 where a computed row is a non-constant term of the state: (X * X) @ it is the variance.

    Notes
    -----
    The distribution parameters ``theta`` are, per uncertain parameter in order, (mean, std)
    for a normal and (low, high) for the uniform mean wind; see ``theta_names``.

    The system matrix depends on mu, m_load and l_f only; the mean wind enters the input,
    linearly in its germ (F_w = c + h xi_w). Its germ is therefore a linear germ of the
    projector, like the KLE germs: the basis is the thesis' (total order N_PCE over all germs),
    the Galerkin products in xi_w are exact, the terms of order >= 2 in xi_w stay exactly zero
    and are dropped, and the wind's terms form their own decoupled block. For the thesis'
    settings this gives the parametric treatment's numbers to round-off with a quarter of the
    quadrature nodes and a smaller system.
    """

    def __init__(
        self,
        settings: Settings,
        uncertain: Sequence[str] = ("mu", "m_load", "l_f", "F_w_mean"),
        time_variant_wind: bool = True,
        order: int = 2,
        quadrature_points: int = 4,
        steer: str = "normal",
        fixed: Mapping[str, float] | None = None,
        delta=None,
    ):
        unknown = [u for u in uncertain if u not in DISTRIBUTIONS]
        if unknown:
            raise ValueError(f"unknown uncertain parameter(s) {unknown}; choose from {list(DISTRIBUTIONS)}")
        if order < 0:
            raise ValueError(f"PCE order must be non-negative, got {order}")
        known = settings.uncertainty.known()
        self.known = {u: v for u, v in known.items() if u in uncertain}
        self.uncertain = tuple(u for u in uncertain if u not in known)
        self.fixed = {**settings.uncertainty.nominal(), **dict(fixed or {})}
        self.vehicle = VehicleParameters.from_settings(settings)
        kle = kle_of_wind(settings.wind, settings.time.t_end)
        n_linear = kle.n_modes if time_variant_wind else 0
        self.wind_scale = settings.wind.sigma * np.sqrt(kle.eigenvalues[:n_linear])
        self.gust_yaw_moment = bool(settings.wind.gust_yaw_moment)
        self.parametric = tuple(u for u in self.uncertain if u not in INPUT_ONLY)
        self.input_germs = tuple(u for u in self.uncertain if u in INPUT_ONLY)
        linear = [DISTRIBUTIONS[u] for u in self.input_germs] + ["normal"] * n_linear
        self.projector = GalerkinProjector([DISTRIBUTIONS[u] for u in self.parametric], linear, order, quadrature_points)
        grid = settings.time
        self.time = grid.output
        self.dt = grid.dt
        st = settings.steering
        if delta is None:
            delta = steering_input(self.time, st.delta_max, st.period, STEERS[steer])
        elif np.shape(delta) != self.time.shape:
            raise ValueError(f"delta has {np.size(delta)} samples but the time grid has {self.time.size}")
        one = np.ones_like(delta)
        # signals [delta, 1 (mean wind's midpoint), 1 (its germ's part, if uncertain), f_j (KLE)]
        self.inputs = np.column_stack([delta, one] + [one] * len(self.input_germs) + list(kle.eigenfunctions(self.time)[:n_linear]))
        self.theta_names = tuple(
            name
            for u in self.uncertain
            for name in ((f"{u}_mean", f"{u}_std") if DISTRIBUTIONS[u] == "normal" else (f"{u}_low", f"{u}_high"))
        )
        self.germ_names = self.parametric + self.input_germs + tuple(f"wind_kle_{j + 1}" for j in range(n_linear))
        # The expanded states are computed in the projector's block order (consecutive decoupled
        # blocks); the moments read them there: the mean from the constant terms, the variance
        # as a sum of squares of the others (one product with a state indicator).
        self.expanded_states = self.projector.block_order(4)
        state, term = np.divmod(self.expanded_states, self.projector.n_terms)
        self.mean_rows = np.array([np.flatnonzero((state == i) & (term == 0))[0] for i in range(4)])
        self.variance_indicator = ((state[:, None] == np.arange(4)) & (term[:, None] != 0)).astype(float)

    def parameters_at_nodes(self, theta):
        """Parameter values (Q,) at the quadrature nodes and their derivatives d value / d theta
        (n_theta, Q), by name, for ``theta`` (n_theta,); ValueError where a node is not physical."""
        theta = np.asarray(theta, float)
        if theta.shape != (len(self.theta_names),):
            raise ValueError(f"theta must have {len(self.theta_names)} entries {self.theta_names}, got shape {theta.shape}")
        xi = self.projector.nodes
        Q = xi.shape[0]
        values = {k: np.full(Q, float(v)) for k, v in self.fixed.items()}
        values["F_w_half"] = np.zeros(Q)  # half width of the mean wind's interval: its germ's coefficient
        dvalues = {k: np.zeros((theta.size, Q)) for k in values}
        for j, u in enumerate(self.uncertain):
            a, b = theta[2 * j], theta[2 * j + 1]
            if DISTRIBUTIONS[u] == "normal":
                if not b > 0:
                    raise ValueError(f"standard deviation of {u} must be positive, got {b}")
                column = self.parametric.index(u)
                values[u] = a + b * xi[:, column]  # (5.8)-(5.10)
                dvalues[u][2 * j], dvalues[u][2 * j + 1] = 1.0, xi[:, column]
            else:
                if not b > a:
                    raise ValueError(f"uniform interval of {u} is degenerate or reversed: low {a}, high {b}")
                # (5.11) F_w = c + h xi_w, xi_w a linear germ of the projector
                values[u], values["F_w_half"] = np.full(Q, 0.5 * (a + b)), np.full(Q, 0.5 * (b - a))
                dvalues[u][2 * j], dvalues[u][2 * j + 1] = 0.5, 0.5
                dvalues["F_w_half"][2 * j], dvalues["F_w_half"][2 * j + 1] = -0.5, 0.5
        self._check_physical(values)
        return values, dvalues

    def _parameters_at_nodes_batch(self, thetas):
        """Parameter values (B, Q) at the nodes for B parameter vectors, and which are admissible
        (the checks of :meth:`parameters_at_nodes`, per vector, without raising)."""
        thetas = np.asarray(thetas, float)
        if thetas.ndim != 2 or thetas.shape[1] != len(self.theta_names):
            raise ValueError(f"thetas must have shape (B, {len(self.theta_names)}) {self.theta_names}, got {thetas.shape}")
        xi = self.projector.nodes
        B, Q = thetas.shape[0], xi.shape[0]
        values = {k: np.full((B, Q), float(v)) for k, v in self.fixed.items()}
        values["F_w_half"] = np.zeros((B, Q))
        ok = np.ones(B, bool)
        for j, u in enumerate(self.uncertain):
            a, b = thetas[:, 2 * j, None], thetas[:, 2 * j + 1, None]
            if DISTRIBUTIONS[u] == "normal":
                ok &= b[:, 0] > 0
                values[u] = a + b * xi[:, self.parametric.index(u)]  # (5.8)-(5.10)
            else:
                ok &= b[:, 0] > a[:, 0]
                values[u], values["F_w_half"] = np.repeat(0.5 * (a + b), Q, axis=1), np.repeat(0.5 * (b - a), Q, axis=1)  # (5.11)
        l_f = values["l_f"]
        ok &= np.all(values["mu"] > 0.0, axis=1) & np.all(l_f > 0.0, axis=1) & np.all(l_f < self.vehicle.wheelbase, axis=1)
        return values, ok

    def _check_physical(self, values):
        """The quadrature nodes must describe physical vehicles: mu > 0 and 0 < l_f < L."""
        if np.any(values["mu"] <= 0.0):
            raise ValueError("mu must stay positive at every quadrature node (mean too small or std too large)")
        if np.any(values["l_f"] <= 0.0) or np.any(values["l_f"] >= self.vehicle.wheelbase):
            raise ValueError("l_f must stay inside (0, wheelbase) at every quadrature node")

    def node_system(self, values, v=None, v_dot=0.0):
        """A (Q,4,4), E (Q,4,2) for inputs [delta, 1], F (Q,4,n_linear) for the linear germs'
        signals (the mean wind's germ, then the KLE germs); at the vehicle's speed, or at the
        speed ``v`` (m/s) changing at ``v_dot`` (m/s^2) (:func:`lst_matrices_at_speed`)."""
        p = replace(self.vehicle, mu=values["mu"], m_load=values["m_load"], l_f=values["l_f"])
        A, B, W = lst_matrices(p) if v is None else lst_matrices_at_speed(p, v, v_dot)
        E = np.stack([B, W * values["F_w_mean"][:, None]], axis=-1)
        gusts = gust_input_column(W, self.gust_yaw_moment)[:, :, None] * self.wind_scale
        F = np.concatenate([W[:, :, None] * values["F_w_half"][:, None, None]] * len(self.input_germs) + [gusts], axis=-1)
        return A, E, F

    def node_system_derivatives(self, values, dvalues, system=None):
        """d(A, E, F)/d theta at the nodes by the complex step in each physical parameter, all
        parameters in one evaluation of the vehicle matrices (stacked along the node axis);
        ``system`` (default :meth:`node_system`) maps node values to the matrices differentiated."""
        moving = [name for name in dvalues if np.any(dvalues[name])]
        n_theta, Q = len(self.theta_names), self.projector.nodes.shape[0]
        if not moving:
            return np.zeros((n_theta, Q, 4, 4)), np.zeros((n_theta, Q, 4, 2)), np.zeros((n_theta, Q, 4, self.projector.n_linear))
        shifted = {}
        for name, v in values.items():
            stacked = np.tile(np.asarray(v, complex), (len(moving), 1))
            if name in moving:
                stacked[moving.index(name)] += 1j * _STEP
            shifted[name] = stacked.ravel()
        weights = np.stack([dvalues[name] for name in moving])  # (n_moving, n_theta, Q)
        return tuple(
            np.einsum("kpq,kq...->pq...", weights, (x.imag / _STEP).reshape((len(moving), Q) + x.shape[1:]))
            for x in (system or self.node_system)(shifted)
        )

    def expanded_system(self, theta):
        """A_PCE (dP, dP) and the input matrix (dP, r) for the signals ``inputs``."""
        values, _ = self.parameters_at_nodes(theta)
        return self.expanded_at_nodes(values, None)

    def expanded_at_nodes(self, values, states, batch=None):
        """A_PCE and the input matrix for parameter values at the nodes, rows and columns
        ``states`` (the excited terms in block order for the moments: the never-excited ones are
        dropped exactly, see GalerkinProjector.excited); ``batch``: values hold that many
        members' nodes one after the other (flat, B Q), giving (B, N, N) and (B, N, r)."""
        A, E, F = self.node_system(values)
        if batch is not None:
            A, E, F = (x.reshape((batch, -1) + x.shape[1:]) for x in (A, E, F))
        pr = self.projector
        return pr.matrix(A, states), np.concatenate([pr.input_matrix(E, states), pr.linear_input_matrix(F, states)], axis=-1)

    def expanded_derivatives(self, values, dvalues):
        """d A_PCE / d theta (p, N, N) and d E_PCE / d theta (p, N, r) of the computed states."""
        dA, dE, dF = self.node_system_derivatives(values, dvalues)
        pr = self.projector
        return pr.matrix(dA, self.expanded_states), np.concatenate([pr.input_matrix(dE, self.expanded_states), pr.linear_input_matrix(dF, self.expanded_states)], axis=-1)

    @with_single_blas_thread
    def moments(self, theta, gradient: bool = False) -> ChaosMoments:
        """Mean and variance of every state at every output time, optionally with gradients.

        The expanded system is discretised exactly for inputs linear between output samples
        (first-order hold); the gradient is the exact derivative of that discretised response.
        Runs with one BLAS thread (:mod:`uqdrive.threads`): the matrices are small.
        """
        values, dvalues = self.parameters_at_nodes(theta)
        A_pce, E_pce = self.expanded_at_nodes(values, self.expanded_states)
        x0 = np.zeros(A_pce.shape[0])
        if not gradient:
            maps = foh_discretise_single(A_pce, E_pce, self.dt)
            return self._moments(lti_response_single(*maps, self.inputs, x0))
        dA_pce, dE_pce = self.expanded_derivatives(values, dvalues)
        maps, dmaps = foh_discretise_single(A_pce, E_pce, self.dt, dA_pce, dE_pce)
        return self._moments(*lti_response_single(*maps, self.inputs, x0, dmaps))

    @with_single_blas_thread
    def moments_batch(self, thetas, every: int = 1) -> BatchMoments:
        """Mean and variance at B parameter vectors in one pass (no gradients).

        The B Galerkin systems are assembled as one stack and discretised and advanced by
        :mod:`uqdrive.numerics.batched_lti`: per member the arithmetic of :meth:`moments`, except
        that the recursion runs block by block (``moments`` merges small blocks into one dense
        system), so the results agree with ``moments`` to rounding (~1e-15 relative).

        Parameters
        ----------
        thetas : ndarray, shape (B, n_theta)
            Distribution parameters in ``theta_names`` order, each in its parameter's units.
        every : int, optional
            Moments at ``time[::every]`` only (up to the last multiple): the same discretised
            model observed less often, with less work.

        Returns
        -------
        BatchMoments
            mean and variance (B, 4, T); inadmissible rows (where ``moments`` raises
            ValueError) are NaN and flagged in ``admissible``.
        """
        values, ok = self._parameters_at_nodes_batch(thetas)
        time = self.time[: (self.time.size - 1) // every * every + 1 : every]
        mean, var = np.full((ok.size, 4, time.size), np.nan), np.full((ok.size, 4, time.size), np.nan)
        n = int(ok.sum())
        if n:
            A_pce, E_pce = self.expanded_at_nodes({k: v[ok].ravel() for k, v in values.items()}, self.expanded_states, batch=n)
            X = lti_response_batched(*foh_discretise_batched(A_pce, E_pce, self.dt), self.inputs, every=every)  # (n, T, N)
            mean[ok] = X[:, :, self.mean_rows].swapaxes(1, 2)
            var[ok] = ((X * X) @ self.variance_indicator).swapaxes(1, 2)
        return BatchMoments(time, mean, var, ok)

    @with_single_blas_thread
    def moments_vjp(self, theta):
        """Moments at ``theta`` and a function giving the gradient of any scalar J of them.

        Returns ``(moments, vjp)``; ``vjp(dJ_dmean, dJ_dvariance)`` (both (4, T)) returns dJ/dtheta
        (n_theta,) by one backward recursion and one adjoint Frechet derivative
        (:func:`uqdrive.adjoint.foh_response_vjp`): its cost does not grow with n_theta, unlike
        the forward sensitivities of ``moments(theta, gradient=True)``.
        """
        values, dvalues = self.parameters_at_nodes(theta)
        A_pce, E_pce = self.expanded_at_nodes(values, self.expanded_states)
        maps = foh_discretise_single(A_pce, E_pce, self.dt)
        X = lti_response_single(*maps, self.inputs, np.zeros(A_pce.shape[0]))
        result = self._moments(X)

        @with_single_blas_thread
        def vjp(dJ_dmean, dJ_dvariance):
            # J depends on X through mean = X[:, mean rows] and variance = X^2 @ indicator.
            G = 2.0 * X * (np.asarray(dJ_dvariance).T @ self.variance_indicator.T)
            G[:, self.mean_rows] = np.asarray(dJ_dmean).T
            dJ_dA, dJ_dE = foh_response_vjp(A_pce, E_pce, self.dt, maps[0], self.inputs, X, G)
            dA_pce, dE_pce = self.expanded_derivatives(values, dvalues)
            return np.einsum("pij,ij->p", dA_pce, dJ_dA) + np.einsum("pij,ij->p", dE_pce, dJ_dE)

        return result, vjp

    def _moments(self, X, S=None) -> ChaosMoments:
        """Moments (4.51) from the computed states X (T, N) and sensitivities S (T, p, N); S is
        overwritten."""
        mean = X[:, self.mean_rows].T
        var = ((X * X) @ self.variance_indicator).T
        dmean = dvar = None
        if S is not None:
            T, p, N = S.shape
            dmean = S[:, :, self.mean_rows].transpose(1, 2, 0)
            S *= X[:, None, :]  # S is ours and not kept: d var = 2 sum X S, without a copy of S
            dvar = 2.0 * (S.reshape(T * p, N) @ self.variance_indicator).reshape(T, p, 4).transpose(1, 2, 0)
        return ChaosMoments(self.time, mean, var, dmean, dvar, X, self.expanded_states, self.projector.n_terms)

    def sobol(self, moments: ChaosMoments, total: bool = False):
        """Sobol indices (n_groups, 4, T) per uncertain parameter, the KLE germs as one group
        (the time-variant wind, as thesis Fig. 5.4); returns (group names, indices)."""
        groups = [[self.germ_names.index(u)] for u in self.uncertain]
        names = list(self.uncertain)
        kle = [j for j, g in enumerate(self.germ_names) if g.startswith("wind_kle_")]
        if kle:
            groups.append(kle)
            names.append("wind (time-variant)")
        c = moments.coefficients.transpose(1, 0, 2)  # (P, 4, T)
        return names, self.projector.chaos.sobol(c, groups, total=total)

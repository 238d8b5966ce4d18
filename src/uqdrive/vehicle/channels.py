"""Measured channels of the single-track model: any subset of the states and the lateral
acceleration a_y, at constant speed or along a speed profile v(t), as moments of the Galerkin PCE.

The chaos model (:class:`uqdrive.vehicle.chaos.LSTChaosModel`) gives the moments of the four
states at one speed. :class:`ChannelChaosModel` wraps it for what a car records:

* a_y = C x + D u (:func:`uqdrive.vehicle.single_track.lateral_acceleration_map`) is a linear
  output of the linear model, so its PCE coefficients are the Galerkin projections
  <Phi C Phi^T> X + <Phi D> u of the expanded states X and inputs u (thesis (4.44)); its mean is
  the constant term and its variance the sum of squares of the others (4.51);
* with a speed v(t) that changes, the model is linear time-varying: each output step
  [t_k, t_k+1] is discretised exactly (first-order hold) with the matrices at the step's mean
  speed (v_k + v_k+1)/2 and slope (v_k+1 - v_k)/dt (:func:`~uqdrive.vehicle.single_track.lst_matrices_at_speed`), a
  second-order accurate splitting in dt; the output map uses v(t_k) at each output time.

Gradients are forward sensitivities, exact derivatives of the discretised recursion. The Monte
Carlo ensembles along a speed profile are :mod:`uqdrive.vehicle.dynamics.ensemble`'s.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import partial
from typing import Sequence

import numpy as np

from ..numerics.discretise import foh_discretise, foh_discretise_derivatives_batched
from ..numerics.integrate import foh_discretise_single, lti_response_single
from ..numerics.recursion import decoupled_blocks
from ..numerics.threads import with_single_blas_thread
from .single_track import A_Y_UNIT, STATE_NAMES, STATE_UNITS, STATES, lateral_acceleration_map

__all__ = ["CHANNELS", "CHANNEL_UNITS", "CHANNEL_NAMES", "ChannelMoments", "ChannelChaosModel"]

#: Every channel a measured ensemble may carry: the four states and the lateral acceleration.
CHANNELS = STATES + ("a_y",)
CHANNEL_UNITS = dict(STATE_UNITS, a_y=A_Y_UNIT)
CHANNEL_NAMES = dict(STATE_NAMES, a_y="lateral acceleration at the centre of gravity")


@dataclass(frozen=True)
class ChannelMoments:
    """Moments of the measured channels on the output grid.

    Attributes
    ----------
    time : ndarray, shape (T,)
    channels : tuple of str
    mean, variance : ndarray, shape (n_channels, T)
    mean_gradient, variance_gradient : ndarray, shape (n_theta, n_channels, T) or None
    """

    time: np.ndarray
    channels: tuple
    mean: np.ndarray
    variance: np.ndarray
    mean_gradient: np.ndarray | None
    variance_gradient: np.ndarray | None

    @property
    def std(self) -> np.ndarray:
        """Standard deviation of each channel, shape (C, T), in the channels' units."""
        return np.sqrt(np.maximum(self.variance, 0.0))


def _phi(v, v_dot, v0=1.0):
    """The functions of the speed the single-track matrices are linear in, [1, 1/v, 1/v^2, v,
    v_dot/v], each scaled by a power of the reference speed v0 (m/s) so that they are of order
    one (a well-conditioned basis)."""
    r = v / v0
    return np.array([1.0, 1.0 / r, 1.0 / r**2, r, v_dot / v])


def _blockwise_foh(A, E, h, dA=None, dE=None):
    """FOH maps of a stack of systems (U, N, N) (with derivatives along (U, p, N, N)) by the
    decoupled blocks of their common pattern (the Galerkin terms with and without the wind's
    linear germ never mix): the exponentials are of the blocks' size."""
    U, N, r = E.shape
    pattern = np.any(A != 0, axis=0) | (np.any(dA != 0, axis=(0, 1)) if dA is not None else False)
    Phi, P, Q = np.zeros((U, N, N)), np.zeros((U, N, r)), np.zeros((U, N, r))
    dPhi = dP = dQ = None
    if dA is not None:
        n_p = dA.shape[1]
        dPhi, dP, dQ = np.zeros((U, n_p, N, N)), np.zeros((U, n_p, N, r)), np.zeros((U, n_p, N, r))
    for b in decoupled_blocks(pattern):
        ix = np.ix_(b, b)
        if dA is None:
            Phi[:, b[:, None], b], P[:, b], Q[:, b] = foh_discretise(A[:, b[:, None], b], E[:, b], h)
            continue
        (Pb, Pp, Qb), (dPb, dPp, dQb) = foh_discretise_derivatives_batched(A[:, b[:, None], b], E[:, b], h, dA[:, :, b[:, None], b], dE[:, :, b])
        Phi[(slice(None),) + ix], P[:, b], Q[:, b] = Pb, Pp, Qb
        dPhi[(slice(None), slice(None)) + ix], dP[:, :, b], dQ[:, :, b] = dPb, dPp, dQb
    return Phi, P, Q, dPhi, dP, dQ


def _check_speed(speed, time) -> np.ndarray | None:
    """The speed profile on the output grid (m/s), or None when it is one constant."""
    if speed is None:
        return None
    v = np.asarray(speed, float)
    if v.shape != time.shape:
        raise ValueError(f"speed profile has shape {v.shape}; the time grid has {time.shape}")
    if not np.all(np.isfinite(v) & (v > 0)):
        raise ValueError("speed profile must be finite and positive (m/s)")
    return None if np.all(v == v[0]) else v


class ChannelChaosModel:
    """Moments of measured channels (a subset of :data:`CHANNELS`) of an :class:`LSTChaosModel`.

    Parameters
    ----------
    model : LSTChaosModel
        The expanded model (its time grid, inputs and uncertain parameters).
    channels : sequence of str
        Channels in the order of the measured statistics.
    speed : ndarray, shape (T,), optional
        Speed v(t_k) (m/s) on the model's output grid; None or a constant keeps the model's
        speed (its time-invariant path).

    Attributes
    ----------
    theta_names, time : as the wrapped model.
    """

    def __init__(self, model, channels: Sequence[str], speed=None):
        unknown = [c for c in channels if c not in CHANNELS]
        if unknown or not channels:
            raise ValueError(f"channels {list(channels)}: choose a non-empty subset of {', '.join(CHANNELS)}")
        self.model = model
        self.channels = tuple(channels)
        self.theta_names = model.theta_names
        self.known = model.known  # declared-known quantities (std 0) are left out of theta by the wrapped model
        self.time = model.time
        self.speed = _check_speed(speed, self.time)
        self._constant_speed = float(model.vehicle.v_c) if self.speed is None else None
        self._output_speed = self.speed
        self._v0 = None if self.speed is None else float(np.mean(self.speed))
        state, term = np.divmod(model.expanded_states, model.projector.n_terms)
        self._beta_rows = np.flatnonzero(state == 2)
        self._a_y_mean = int(np.flatnonzero(term[self._beta_rows] == 0)[0])

    # -- the lateral acceleration's Galerkin output map ---------------------------------------
    def _output_system(self, values, v):
        """C, D, F of a_y in the (Q, 4, .) layout of the model's system (the beta row carries
        them), so that the projector's Galerkin products apply unchanged."""
        m = self.model
        p = replace(m.vehicle, mu=values["mu"], m_load=values["m_load"], l_f=values["l_f"], v_c=v)
        C, D_delta, D_w = lateral_acceleration_map(p)
        Q = C.shape[0]
        dtype = C.dtype
        Cf = np.zeros((Q, 4, 4), dtype)
        Cf[:, 2, :] = C
        Ef = np.zeros((Q, 4, 2), dtype)
        Ef[:, 2, 0], Ef[:, 2, 1] = D_delta, D_w * values["F_w_mean"]
        n_in = len(m.input_germs)
        Ff = np.zeros((Q, 4, m.projector.n_linear), dtype)
        Ff[:, 2, :n_in] = (D_w * values["F_w_half"])[:, None]
        Ff[:, 2, n_in:] = D_w[:, None] * m.wind_scale
        return Cf, Ef, Ff

    def _output_map(self, values, dvalues, v, gradient):
        """Galerkin output map of a_y onto the computed states: Cy (Nb, N), Dy (Nb, r) and their
        derivatives (p, Nb, N), (p, Nb, r) (None without ``gradient``)."""
        m, pr, states = self.model, self.model.projector, self.model.expanded_states
        rows = self._beta_rows
        Cf, Ef, Ff = self._output_system(values, v)
        Cy = pr.matrix(Cf, states)[rows]
        Dy = np.concatenate([pr.input_matrix(Ef, states), pr.linear_input_matrix(Ff, states)], axis=-1)[rows]
        if not gradient:
            return Cy, Dy, None, None
        dC, dE, dF = m.node_system_derivatives(values, dvalues, system=partial(self._output_system, v=v))
        dCy = pr.matrix(dC, states)[:, rows]
        dDy = np.concatenate([pr.input_matrix(dE, states), pr.linear_input_matrix(dF, states)], axis=-1)[:, rows]
        return Cy, Dy, dCy, dDy

    # -- responses ------------------------------------------------------------------------------
    def _response(self, values, dvalues, gradient):
        """Expanded states X (T, N) and sensitivities S (T, p, N) (None without ``gradient``)."""
        m = self.model
        states = m.expanded_states
        x0 = np.zeros(states.size)
        if self.speed is None:
            A_pce, E_pce = m.expanded_at_nodes(values, states)
            if not gradient:
                return lti_response_single(*foh_discretise_single(A_pce, E_pce, m.dt), m.inputs, x0), None
            dA, dE = m.expanded_derivatives(values, dvalues)
            maps, dmaps = foh_discretise_single(A_pce, E_pce, m.dt, dA, dE)
            return lti_response_single(*maps, m.inputs, x0, dmaps)
        return self._ltv_response(values, dvalues, gradient)

    def _speed_basis(self, system, values, dvalues, gradient):
        """Galerkin matrices of ``system`` as a combination sum_i phi_i(v, v_dot) M_i.

        The single-track matrices are linear in phi = [1, 1/v, 1/v^2, v, v_dot/v] (:data:`_PHI`),
        so the node matrices at five speeds determine the M_i, projected once (the projector is
        linear) instead of at every step; a sixth speed checks the decomposition.
        """
        m, pr, states = self.model, self.model.projector, self.model.expanded_states
        v0 = self._v0
        probes = [(v0 * a, v0 * b) for a, b in ((0.5, 0.0), (1.0, 0.0), (2.0, 0.0), (0.75, 1.0), (1.5, -1.0), (1.2, 0.5))]
        Phi = np.array([_phi(v, vd, v0) for v, vd in probes])  # (6, 5)
        inv = np.linalg.inv(Phi[:5])

        def project(mats):
            A, E, F = mats
            return pr.matrix(A, states), np.concatenate([pr.input_matrix(E, states), pr.linear_input_matrix(F, states)], axis=-1)

        at = [project(system(values, v=v, v_dot=vd)) for v, vd in probes]
        basis = [np.einsum("ij,j...->i...", inv, np.stack([a[k] for a in at[:5]])) for k in range(2)]
        for k in range(2):
            check = np.tensordot(Phi[5], basis[k], axes=1)
            if not np.allclose(check, at[5][k], rtol=1e-9, atol=1e-12 * np.abs(at[5][k]).max()):
                raise RuntimeError("the single-track matrices are not linear in [1, 1/v, 1/v^2, v, v_dot/v]")
        if not gradient:
            return basis, None
        dat = [project(m.node_system_derivatives(values, dvalues, system=partial(system, v=v, v_dot=vd))) for v, vd in probes[:5]]
        dbasis = [np.einsum("ij,j...->i...", inv, np.stack([a[k] for a in dat])) for k in range(2)]
        return basis, dbasis

    def _ltv_response(self, values, dvalues, gradient):
        """x_k+1 = Phi_k x_k + P_k g_k + Q_k g_k+1 with each step's maps at its mean speed."""
        m = self.model
        v, g, dt = self.speed, m.inputs, m.dt
        K, N = v.size - 1, m.expanded_states.size
        (A_b, E_b), d = self._speed_basis(m.node_system, values, dvalues, gradient)
        # steps at the same speed and slope (the constant parts of a profile) share their maps
        keys = np.column_stack([0.5 * (v[1:] + v[:-1]), np.diff(v) / dt])
        unique, which = np.unique(keys, axis=0, return_inverse=True)
        phis = np.array([_phi(*key, self._v0) for key in unique])  # (U, 5)
        A_pce, E_pce = np.tensordot(phis, A_b, axes=1), np.tensordot(phis, E_b, axes=1)
        dA_pce = np.tensordot(phis, d[0], axes=1) if gradient else None
        dE_pce = np.tensordot(phis, d[1], axes=1) if gradient else None
        Phi, P, Q, dPhi, dP, dQ = _blockwise_foh(A_pce, E_pce, dt, dA_pce, dE_pce)
        X = np.zeros((K + 1, N))
        S = np.zeros((K + 1, len(self.theta_names), N)) if gradient else None
        for k, u in enumerate(np.ravel(which)):
            if gradient:
                S[k + 1] = S[k] @ Phi[u].T + dPhi[u] @ X[k] + dP[u] @ g[k] + dQ[u] @ g[k + 1]
            X[k + 1] = Phi[u] @ X[k] + P[u] @ g[k] + Q[u] @ g[k + 1]
        return X, S

    def _a_y(self, values, dvalues, X, S, gradient):
        """PCE coefficients of a_y (T, Nb) and their sensitivities (T, p, Nb)."""
        g = self.model.inputs
        if self.speed is None:
            Cy, Dy, dCy, dDy = self._output_map(values, dvalues, self._constant_speed, gradient)
            Y = X @ Cy.T + g @ Dy.T
            if not gradient:
                return Y, None
            dY = S @ Cy.T + np.einsum("tn,pbn->tpb", X, dCy) + np.einsum("tr,pbr->tpb", g, dDy)
            return Y, dY
        T = X.shape[0]
        Y = np.empty((T, self._beta_rows.size))
        dY = np.empty((T, S.shape[1], self._beta_rows.size)) if gradient else None
        system = lambda vals, v, v_dot: self._output_system(vals, v)  # noqa: E731 (a_y does not depend on v_dot)
        (C_b, D_b), d = self._speed_basis(system, values, dvalues, gradient)
        rows = self._beta_rows
        for k in range(T):
            phi = _phi(self._output_speed[k], 0.0, self._v0)
            Cy, Dy = np.tensordot(phi, C_b[:, rows], axes=1), np.tensordot(phi, D_b[:, rows], axes=1)
            Y[k] = Cy @ X[k] + Dy @ g[k]
            if gradient:
                dCy, dDy = np.tensordot(phi, d[0][:, :, rows], axes=1), np.tensordot(phi, d[1][:, :, rows], axes=1)
                dY[k] = S[k] @ Cy.T + dCy @ X[k] + dDy @ g[k]
        return Y, dY

    @with_single_blas_thread
    def moments(self, theta, gradient: bool = False) -> ChannelMoments:
        """Mean and variance (n_channels, T) of the channels, optionally with their gradients."""
        m = self.model
        values, dvalues = m.parameters_at_nodes(theta)
        X, S = self._response(values, dvalues, gradient)
        mean, var, dmean, dvar = [], [], [], []
        for c in self.channels:
            if c == "a_y":
                Y, dY = self._a_y(values, dvalues, X, S, gradient)
                rest = np.ones(Y.shape[1], bool)
                rest[self._a_y_mean] = False
                mean.append(Y[:, self._a_y_mean])
                var.append(np.sum(Y[:, rest] ** 2, axis=1))
                if gradient:
                    dmean.append(dY[:, :, self._a_y_mean].T)
                    dvar.append(2.0 * np.einsum("tb,tpb->pt", Y[:, rest], dY[:, :, rest]))
                continue
            i = STATES.index(c)
            rows, ind = m.mean_rows[i], m.variance_indicator[:, i]
            mean.append(X[:, rows])
            var.append((X * X) @ ind)
            if gradient:
                dmean.append(S[:, :, rows].T)
                dvar.append(2.0 * np.einsum("tn,tpn,n->pt", X, S, ind))
        grad = (np.stack(dmean, axis=1), np.stack(dvar, axis=1)) if gradient else (None, None)
        return ChannelMoments(self.time, self.channels, np.stack(mean), np.stack(var), *grad)

"""Stochastic LQR on the PCE model (thesis 4.66, 5.35-5.38): a constant gain K on the original
state, minimising the finite-horizon cost of the expanded closed loop of the lane-keeping case.

The expanded closed loop is A_PCE(K) = A_0 + sum_j K_j M_j (affine in K); its response is the
exact first-order-hold discretisation, and the gradient of the cost is the exact derivative of
that discretised response, so no fixed-step simulation runs inside the optimiser.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
import numpy as np
from scipy.optimize import minimize

from ..numerics.galerkin import GalerkinProjector
from ..numerics.integrate import foh_discretise_single, lti_response_single
from ..settings import Settings, TimeGrid
from ..vehicle.montecarlo import gust_input_column, wind_kle
from ..vehicle.uncertainty import ParameterDistribution
from ..vehicle.single_track import VehicleParameters, lst_matrices

__all__ = ["LaneKeepingCase", "ClosedLoopChaos", "mean_variance_weights"]


@dataclass(frozen=True)
class LaneKeepingCase:
    """Thesis Fig 5.8: initial lateral offset U(y_low, y_high) m and yaw U(-psi, psi) deg, zero
    yaw rate and slip, straight reference y = 0; evaluated on [0, horizon] s with step dt."""

    y_low: float = 0.0
    y_high: float = 1.75
    psi_deg: float = 5.0
    horizon: float = 2.0
    dt: float = 0.01

    @classmethod
    def from_settings(cls, settings: Settings, horizon: float | None = None) -> "LaneKeepingCase":
        """The case of the settings' controller (initial offset range, yaw, horizon) on the time grid's dt."""
        c = settings.control
        return cls(c.y0[0], c.y0[1], c.psi0_deg, c.horizon if horizon is None else horizon, settings.time.dt)


def mean_variance_weights(n_terms: int, gamma: float) -> np.ndarray:
    """Diagonal D of (5.35)-(5.36): gamma on the mean term, 1 - gamma on every other term."""
    d = np.full(n_terms, 1.0 - gamma)
    d[0] = gamma
    return d


class ClosedLoopChaos:
    """Galerkin PCE of x' = (A(xi) + B(xi) K) x + W(xi) F_w(t, xi), x(0) = x0(xi).

    Parametric germs: mu, m_load, l_f (normal), mean wind (uniform), with the distributions of
    ``distribution``; linear germs: the KLE wind germs (optional) and the two uniform initial
    condition germs of the lane-keeping case.
    """

    def __init__(self, settings: Settings, case: LaneKeepingCase, distribution: ParameterDistribution | None = None,
                 order: int = 2, quadrature_points: int = 4, time_variant_wind: bool = True):
        dist = distribution if distribution is not None else ParameterDistribution.from_settings(settings.uncertainty)
        kle = wind_kle(settings)
        n_kle = kle.n_modes if time_variant_wind else 0
        self.projector = pr = GalerkinProjector(["normal", "normal", "normal", "uniform"], ["normal"] * n_kle + ["uniform", "uniform"], order, quadrature_points)
        draws = dist.from_germs(pr.nodes)
        p = replace(VehicleParameters.from_settings(settings), mu=draws["mu"], m_load=draws["m_load"], l_f=draws["l_f"])
        A, B, W = lst_matrices(p)
        Q = A.shape[0]
        self.A0 = pr.matrix(A)
        self.M = np.stack([pr.matrix(B[:, :, None] * np.eye(4)[j][None, None, :]) for j in range(4)])  # d A_PCE / d K_j
        scale = settings.wind.sigma * np.sqrt(kle.eigenvalues[:n_kle])
        W_gust = gust_input_column(W, settings.wind.gust_yaw_moment)
        F = np.zeros((Q, 4, n_kle + 2))
        F[:, :, :n_kle] = W_gust[:, :, None] * scale
        self.E = np.concatenate([pr.input_matrix((W * draws["F_w_mean"][:, None])[:, :, None]), pr.linear_input_matrix(F)[:, :n_kle]], axis=1)
        x0_mean = np.zeros((Q, 4))
        x0_mean[:, 3] = 0.5 * (case.y_low + case.y_high)
        x0_lin = np.zeros((Q, 4, n_kle + 2))
        x0_lin[:, 3, n_kle] = 0.5 * (case.y_high - case.y_low)  # y0 = mid + half xi
        x0_lin[:, 0, n_kle + 1] = np.deg2rad(case.psi_deg)  # psi0 = psi xi
        self.X0 = pr.initial_state(x0_mean) + pr.linear_initial_state(x0_lin)
        # Keep only the excited terms (exact, see GalerkinProjector.excited).
        self.keep = keep = pr.state_mask(4)
        self.A0, self.M = self.A0[np.ix_(keep, keep)], self.M[:, keep][:, :, keep]
        self.E, self.X0 = self.E[keep], self.X0[keep]
        grid = TimeGrid(case.horizon, case.dt, case.dt)
        self.time = grid.output
        self.inputs = np.column_stack([np.ones_like(self.time), kle.eigenfunctions(self.time)[:n_kle].T])
        self.dt = case.dt
        self.n_terms = pr.n_terms

    def response(self, K, gradient: bool = False):
        """Expanded closed-loop response X (T, 4 P) and, if asked, dX/dK (T, 4, 4 P)."""
        K = np.asarray(K, float).ravel()
        A = self.A0 + np.tensordot(K, self.M, axes=(0, 0))
        if not gradient:
            return self.projector.scatter(lti_response_single(*foh_discretise_single(A, self.E, self.dt), self.inputs, self.X0), self.keep)
        maps, dmaps = foh_discretise_single(A, self.E, self.dt, self.M, np.zeros((4,) + self.E.shape))
        X, S = lti_response_single(*maps, self.inputs, self.X0, dmaps)
        return self.projector.scatter(X, self.keep), self.projector.scatter(S, self.keep)

    def moments(self, K):
        """Mean and variance (4, T) of the states and of the steering u = K x."""
        c = self.projector.coefficients(self.response(K))  # (T, 4, P)
        u = np.einsum("i,tip->tp", np.asarray(K, float).ravel(), c)
        return c[:, :, 0].T, np.sum(c[:, :, 1:] ** 2, axis=-1).T, u[:, 0], np.sum(u[:, 1:] ** 2, axis=-1)

    def cost(self, K, Q, R, gamma: float, gradient: bool = False):
        """Finite-horizon cost (5.38) with Q_PCE = Q (x) D and R_PCE = R D, D from (5.35)-(5.36).

        In coefficients: J = sum_t sum_k D_k x_k' (Q + K' R K) x_k, x_k the k-th coefficient vector.
        """
        K = np.asarray(K, float).ravel()
        D = mean_variance_weights(self.n_terms, gamma)
        S = np.asarray(Q, float) + R * np.outer(K, K)
        out = self.response(K, gradient)
        X = out[0] if gradient else out
        c = self.projector.coefficients(X)  # (T, 4, P)
        Sc = np.einsum("ij,tjp->tip", S, c)
        J = float(np.einsum("p,tip,tip->", D, c, Sc))
        if not gradient:
            return J
        dc = self.projector.coefficients(out[1])  # (T, 4 params, 4 states, P)
        Kc = np.einsum("i,tip->tp", K, c)  # u coefficients
        g = 2.0 * np.einsum("p,tip,tjip->j", D, Sc, dc) + 2.0 * R * np.einsum("p,tjp,tp->j", D, c, Kc)
        return J, g

    def synthesise(self, K0, Q, R, gamma: float):
        """Minimise (5.38) over K from K0 with BFGS and the exact gradient; returns (K, result)."""
        K0 = np.asarray(K0, float).ravel()
        J0 = self.cost(K0, Q, R, gamma)

        def f(k):
            J, g = self.cost(k, Q, R, gamma, gradient=True)
            return J / J0, g / J0

        res = minimize(f, K0, jac=True, method="BFGS", options={"gtol": 1e-9, "maxiter": 500})
        return res.x, res

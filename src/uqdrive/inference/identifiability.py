"""Structural identifiability of the LST parameters by the non-linear observability rank condition
(thesis 3.9-3.12): the state is augmented with theta = [mu, m_load, l_f, mean wind] (constant),
Lie derivatives of the output are taken symbolically, and the rank is evaluated at a point.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np
import sympy as sp


__all__ = ["ObservabilityResult", "observability_analysis"]

PARAMETERS = ("mu", "m_load", "l_f", "F_w_mean")


@dataclass(frozen=True)
class ObservabilityResult:
    """Rank of the non-linear observability matrix and the column-removal test.

    Attributes
    ----------
    names : tuple of str
        Augmented states [psi, psi_dot, beta, y, mu, m_load, l_f, F_w_mean].
    rank : int
        Numeric rank of O_NL at the evaluation point (full rank: 8).
    removal_rank : dict
        Rank after deleting each column; an unchanged rank means that variable's
        identifiability cannot be guaranteed.
    singular_values : ndarray
    null_vector : ndarray
        Right singular vector of the smallest singular value (in column-scaled units): the
        direction along which the output does not change.
    """

    names: tuple
    rank: int
    removal_rank: dict
    singular_values: np.ndarray
    null_vector: np.ndarray

    @property
    def unidentifiable(self) -> list:
        return [n for n, r in self.removal_rank.items() if r == self.rank]


def _lst_symbolic(config: Mapping[str, Any]):
    """Augmented LST (3.12) with symbolic states and parameters, numeric constants."""
    veh = config["vehicle"]
    psi, psi_dot, beta, y = sp.symbols("psi psi_dot beta y")
    mu, m_load, l_f, F_w = sp.symbols("mu m_load l_f F_w_mean")
    delta = sp.Symbol("delta")
    F = sp.Float  # numeric constants as floats: rationals make the Lie derivatives swell
    L, g, v = F(veh["wheelbase"]), F(veh["g"]), F(veh["speed_kmh"] / 3.6)
    m = F(veh["m_base"]) + m_load
    I_z = m * F(veh["J0"])
    l_r = L - l_f
    C = F(config["tyre"]["C"])
    c_f = m * g * l_r / L * F(veh["c_Sf"]) * C * mu
    c_r = m * g * l_f / L * F(veh["c_Sr"]) * C * mu
    M_c = F(veh["M_c"])
    f = sp.Matrix(
        [
            psi_dot,
            -(c_f * l_f**2 + c_r * l_r**2) / (I_z * v) * psi_dot + (c_r * l_r - c_f * l_f) / I_z * beta + l_f * c_f / I_z * delta + M_c * F_w / I_z,
            ((c_r * l_r - c_f * l_f) / (m * v**2) - 1) * psi_dot - (c_f + c_r) / (m * v) * beta + c_f / (m * v) * delta + F_w / (m * v),
            v * psi,
            0,
            0,
            0,
            0,
        ]
    )
    x = sp.Matrix([psi, psi_dot, beta, y, mu, m_load, l_f, F_w])
    return x, f, delta


def observability_analysis(config: Mapping[str, Any], state=None, tol: float = 1e-9) -> ObservabilityResult:
    """O_NL = d/dx [g, L_f g, ..., L_f^{n-1} g] with g = the four measured states (3.9)-(3.11).

    Evaluated with the constant input delta = delta_max at the nominal parameters and the given
    state (default: a generic non-zero state, since at rest the Lie derivatives lose the terms
    that carry the state). The rank uses singular values relative to the largest, after scaling
    each column by its variable's nominal magnitude and each row to unit norm (the k-th Lie
    derivative grows like |eigenvalue|^k, which would otherwise swamp the rank test).
    """
    x, f, delta = _lst_symbolic(config)
    n = x.shape[0]
    g_out = x[:4, :]
    rows = [g_out.jacobian(x)]
    lie = g_out
    for _ in range(n - 1):
        lie = lie.jacobian(x) * f
        rows.append(lie.jacobian(x))
    O = sp.Matrix.vstack(*rows)
    unc = config["uncertainty"]
    nominal = {"mu": unc["mu"]["mean"], "m_load": unc["m_load"]["mean"], "l_f": unc["l_f"]["mean"], "F_w_mean": 0.5 * (unc["F_w_mean"]["low"] + unc["F_w_mean"]["high"]) + 100.0}
    state = state if state is not None else {"psi": 0.05, "psi_dot": 0.2, "beta": 0.01, "y": 1.0}
    point = {s: state[s.name] if s.name in state else nominal[s.name] for s in x}
    point[delta] = np.deg2rad(config["steering"]["delta_max_deg"])
    values = np.array(sp.lambdify(list(point), O, "numpy")(*point.values()), dtype=float)
    scale = np.array([max(abs(point[s]), 1e-3) for s in x])
    values = values * scale  # columns in relative units, so the rank is not a unit artefact
    norms = np.linalg.norm(values, axis=1, keepdims=True)
    values = values[norms[:, 0] > 0] / norms[norms[:, 0] > 0]
    names = tuple(str(s) for s in x)

    def rank(M):
        sv = np.linalg.svd(M, compute_uv=False)
        return int(np.sum(sv > tol * sv[0])), sv

    r, sv = rank(values)
    null = np.linalg.svd(values)[2][-1]
    removal = {names[j]: rank(np.delete(values, j, axis=1))[0] for j in range(n)}
    return ObservabilityResult(names, r, removal, sv, null / np.abs(null).max())

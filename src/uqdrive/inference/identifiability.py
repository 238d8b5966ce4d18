"""Structural identifiability of the LST parameters by the non-linear observability rank condition
(thesis 3.9-3.12): the state is augmented with theta = [mu, m_load, l_f, mean wind] (constant),
and the rank of the Lie-derivative Jacobian is evaluated at a point.
"""

from __future__ import annotations

from dataclasses import dataclass
import numpy as np
import sympy as sp

from ..settings import Settings

__all__ = ["ObservabilityResult", "observability_analysis", "observability_matrix", "channel_observability", "unidentifiable_parameters"]

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
    singular_values : ndarray, shape (8,)
        Singular values of the column-scaled O_NL, largest first.
    null_vector : ndarray, shape (8,)
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
        """Parameters whose removal keeps the rank: those the outputs cannot distinguish."""
        return [n for n, r in self.removal_rank.items() if r == self.rank]


def _lst_symbolic(settings: Settings):
    """Augmented LST (3.12) with symbolic states and parameters, numeric constants."""
    veh = settings.vehicle
    psi, psi_dot, beta, y = sp.symbols("psi psi_dot beta y")
    mu, m_load, l_f, F_w = sp.symbols("mu m_load l_f F_w_mean")
    delta = sp.Symbol("delta")
    F = sp.Float  # numeric constants as floats: rationals make the Lie derivatives swell
    L, g, v = F(veh.wheelbase), F(veh.g), F(veh.v_c)
    m = F(veh.m_base) + m_load
    I_z = m * F(veh.J0)
    l_r = L - l_f
    C = F(veh.C)
    c_f = m * g * l_r / L * F(veh.c_Sf) * C * mu
    c_r = m * g * l_f / L * F(veh.c_Sr) * C * mu
    M_c = F(veh.M_c)
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


def _nominal(settings: Settings) -> dict:
    """The evaluation point of the parameters: the means, the mean wind 100 N past its midpoint
    (a zero wind would hide its column)."""
    nominal = settings.uncertainty.nominal()
    return {**nominal, "F_w_mean": nominal["F_w_mean"] + 100.0}


def _lie_jacobian(A, b, x, dA, db, n: int) -> np.ndarray:
    """Rows d/dz L_F^k h, k = 0..n-1, of the augmented affine system F(z) = (A(p) x + b(p), 0).

    For h(z) = x and constant parameters p, L_F^k h = A^k x + A^(k-1) b (k >= 1), so the state
    columns are A^k and the parameter columns the derivative of that expression along p.

    Parameters
    ----------
    A : (4, 4) ndarray, b : (4,) ndarray
        Drift at the evaluation point (thesis (3.12) with delta fixed).
    x : (4,) ndarray
        State at the evaluation point.
    dA : (m, 4, 4) ndarray, db : (m, 4) ndarray
        Derivatives of A and b along each of the m parameters.
    n : int
        Number of Lie derivatives (the augmented dimension).

    Returns
    -------
    (4 n, 4 + m) ndarray
    """
    m = dA.shape[0]
    rows = [np.hstack([np.eye(4), np.zeros((4, m))])]
    Ak, dAk = np.eye(4), np.zeros((m, 4, 4))  # A^(k-1) and its derivative
    for _ in range(1, n):
        drive = A @ x + b  # A x + b, so L^k h = A^(k-1) (A x + b)
        d_drive = dA @ x + db  # (m, 4)
        value_x = Ak @ A
        value_p = dAk @ drive + np.einsum("ij,mj->mi", Ak, d_drive)  # (m, 4)
        rows.append(np.hstack([value_x, value_p.T]))
        dAk = dAk @ A + Ak @ dA  # product rule for A^k = A^(k-1) A
        Ak = Ak @ A
    return np.vstack(rows)


def observability_matrix(settings: Settings, state=None, n_lie: int | None = None):
    """O_NL = d/dz [g, L_f g, ..., L_f^{n-1} g] with g = the four measured states (3.9)-(3.11).

    Evaluated with the constant input delta = delta_max at the nominal parameters and the given
    state (default: a generic non-zero state, since at rest the Lie derivatives lose the terms
    that carry the state). The LST is affine in the state, so the Lie derivatives are matrix
    powers (see `_lie_jacobian`); their parameter derivatives are taken by complex step, exact to
    rounding, where symbolic Lie derivatives of order 7 took ~40 s to swell.

    Returns
    -------
    x : sympy Matrix (8, 1)
        The augmented state's symbols.
    point : dict
        Symbol -> value of the evaluation point.
    values : (4 n_lie, 8) ndarray
        O_NL at the point (n_lie defaults to the augmented dimension 8).
    """
    x, f, delta = _lst_symbolic(settings)
    n = x.shape[0] if n_lie is None else n_lie
    states, params = list(x[:4]), list(x[4:])
    drift = f[:4, :]
    A_sym = drift.jacobian(states)
    b_sym = drift.subs({s: 0 for s in states})  # exact: the drift is affine in the state
    A_fn = sp.lambdify(params + [delta], A_sym, "numpy")
    b_fn = sp.lambdify(params + [delta], b_sym, "numpy")
    nominal = _nominal(settings)
    state = state if state is not None else {"psi": 0.05, "psi_dot": 0.2, "beta": 0.01, "y": 1.0}
    point = {s: state[s.name] if s.name in state else nominal[s.name] for s in x}
    point[delta] = settings.steering.delta_max
    p0 = np.array([point[s] for s in params], dtype=complex)
    x0 = np.array([point[s] for s in states], dtype=float)

    def drift_at(p):
        return np.array(A_fn(*p, point[delta]), dtype=complex), np.array(b_fn(*p, point[delta]), dtype=complex).ravel()

    A0, b0 = (v.real for v in drift_at(p0))
    dA, db = np.empty((len(params), 4, 4)), np.empty((len(params), 4))
    for j in range(len(params)):
        h = 1e-20 * max(abs(p0[j]), 1.0)
        Aj, bj = drift_at(p0 + 1j * h * np.eye(len(params))[j])
        dA[j], db[j] = Aj.imag / h, bj.imag / h
    return x, point, _lie_jacobian(A0, b0, x0, dA, db, n)


def observability_analysis(settings: Settings, state=None, tol: float = 1e-9) -> ObservabilityResult:
    """Rank of O_NL (`observability_matrix`) and the column-removal test (thesis sec. 5.3.1).

    The rank uses singular values relative to the largest, after scaling each column by its
    variable's nominal magnitude and each row to unit norm (the k-th Lie derivative grows like
    |eigenvalue|^k, which would otherwise swamp the rank test).
    """
    x, point, values = observability_matrix(settings, state)
    scale = np.array([max(abs(point[s]), 1e-3) for s in x])
    values = values * scale  # columns in relative units, so the rank is not a unit artefact
    return _rank_test(values, tuple(str(s) for s in x), tol)


def _rank_test(O, names, tol) -> "ObservabilityResult":
    """Rank of the column-scaled observability matrix O (rows, n) after scaling each non-zero row
    to unit norm, its null direction, and the rank with each column removed (thesis sec. 5.3.1)."""
    norms = np.linalg.norm(O, axis=1, keepdims=True)
    O = O[norms[:, 0] > 0] / norms[norms[:, 0] > 0]

    def rank(M):
        sv = np.linalg.svd(M, compute_uv=False)
        return int(np.sum(sv > tol * sv[0])), sv

    r, sv = rank(O)
    null = np.linalg.svd(O)[2][-1]
    removal = {names[j]: rank(np.delete(O, j, axis=1))[0] for j in range(len(names))}
    return ObservabilityResult(names, r, removal, sv, null / np.abs(null).max())


#: What to record to separate a parameter that a channel set leaves open.
_RECORD_HINT = {
    "mu": "the yaw rate psi_dot or the lateral acceleration a_y",
    "l_f": "both the yaw rate psi_dot and the lateral acceleration a_y (or beta)",
    "F_w_mean": "the yaw rate psi_dot and the lateral acceleration a_y",
    "m_load": "the load (pass --m-load): the mass only scales the wind's effect",
}


def _lst_outputs(settings: Settings, channels):
    """Symbolic outputs h(x, theta, delta) of ``channels``: states as they are and
    a_y = v (beta_dot + psi_dot) of the LST (:func:`uqdrive.vehicle.single_track.lateral_acceleration_map`)."""
    x, f, delta = _lst_symbolic(settings)
    v = sp.Float(settings.vehicle.v_c)
    by_name = {"psi": x[0], "psi_dot": x[1], "beta": x[2], "y": x[3], "a_y": sp.expand(v * (f[2] + x[1]))}
    return x, f, delta, [by_name[c] for c in channels]


def channel_observability(settings: Settings, channels, parameters=PARAMETERS, state=None, tol: float = 1e-9) -> ObservabilityResult:
    """The rank test of :func:`observability_analysis` for the measured ``channels`` (a subset of
    psi, psi_dot, beta, y, a_y) with only ``parameters`` unknown (the others at their nominal
    values, as identify fixes m_load).

    The outputs are affine in the state, h = H(theta) x + d(theta) (a_y = C x + D u), so the Lie
    derivatives are L^0 h = H x + d and L^k h = H A^(k-1) (A x + b) (thesis (3.9)-(3.11)); the
    Jacobian in the augmented state z = (x, theta) is taken by complex step, exact to rounding.
    """
    x, f, delta, outputs = _lst_outputs(settings, channels)
    states, params = list(x[:4]), list(x[4:])
    free = [p for p in params if str(p) in parameters]
    drift = f[:4, :]
    h = sp.Matrix(outputs)
    fns = [sp.lambdify(params + [delta], e, "numpy") for e in (drift.jacobian(states), drift.subs({s: 0 for s in states}),
                                                              h.jacobian(states), h.subs({s: 0 for s in states}))]
    nominal = _nominal(settings)
    state = state if state is not None else {"psi": 0.05, "psi_dot": 0.2, "beta": 0.01, "y": 1.0}
    d0 = settings.steering.delta_max
    z0 = np.array([state[str(s)] for s in states] + [nominal[str(p)] for p in free], complex)
    n = 4 + len(free)

    def lie(z):
        p = {str(s): nominal[str(s)] for s in params}
        p.update({str(s): z[4 + j] for j, s in enumerate(free)})
        args = [p[str(s)] for s in params] + [d0]
        A, b, H, d = (np.array(fn(*args), dtype=complex).reshape(shape) for fn, shape in
                      zip(fns, [(4, 4), (4,), (len(outputs), 4), (len(outputs),)]))
        xs = z[:4]
        rows, drive, Ak = [H @ xs + d], A @ xs + b, np.eye(4)
        for _ in range(1, n):
            rows.append(H @ Ak @ drive)
            Ak = Ak @ A
        return np.concatenate(rows)

    step = 1e-20
    O = np.column_stack([lie(z0 + 1j * step * max(abs(z0[j]), 1.0) * np.eye(n)[j]).imag / (step * max(abs(z0[j]), 1.0)) for j in range(n)])
    scale = np.maximum(np.abs(z0.real), 1e-3)
    return _rank_test(O * scale, tuple(str(s) for s in states + free), tol)


def unidentifiable_parameters(settings: Settings, channels, parameters=PARAMETERS) -> dict:
    """Parameters of ``parameters`` that the ``channels`` cannot separate (rank test of
    :func:`channel_observability`), each with what to record instead."""
    result = channel_observability(settings, channels, parameters)
    return {p: _RECORD_HINT.get(p, "more channels") for p in parameters if p in result.unidentifiable}

"""Exact first-order-hold discretisation of LTI systems x' = A x + E g (g linear between samples):
batched over systems, and for one system with the exact derivatives of its maps.
"""

from __future__ import annotations

import threading
from collections import OrderedDict

import numpy as np

__all__ = ["foh_discretise", "foh_discretise_derivatives", "foh_discretise_derivatives_batched"]


def foh_discretise(A, E, h: float):
    """Exact discretisation of x' = A x + E g(t) for g linear between samples (first-order hold).

    Van Loan's block exponential exp([[A, I, 0], [0, 0, I], [0, 0, 0]] h) has the top row
    [Phi, J_0, J_1] with J_0 = int_0^h e^{A s} ds and J_1 = int_0^h e^{A s} (h - s) ds; they are
    computed here on d x d matrices by scaling and squaring (Taylor series of e^X, phi_1, phi_2
    at h / 2^s, then doublings of the step), not as the 3d x 3d exponential. With
    Gamma_0 = J_0 E and Gamma_1 = J_1 E,
    x_{k+1} = Phi x_k + P g_k + Q g_{k+1} with Q = Gamma_1 / h and P = Gamma_0 - Q.

    Parameters
    ----------
    A : ndarray, shape (..., d, d)
    E : ndarray, shape (..., d, r)
    h : float
        Step (s).

    Returns
    -------
    Phi : ndarray, shape (..., d, d)
    P, Q : ndarray, shape (..., d, r)
    """
    A = np.asarray(A, float)
    E = np.asarray(E, float)
    Phi, J0, J1_h = _step_maps(A, h)
    Q = J1_h @ E
    return Phi.copy(), J0 @ E - Q, Q


#: Largest A (bytes) whose step maps :data:`_STEP_MAPS` keeps, and how many it keeps.
_STEP_MAPS_BYTES, _STEP_MAPS_ENTRIES = 1 << 21, 8
_STEP_MAPS: OrderedDict = OrderedDict()
_STEP_MAPS_LOCK = threading.Lock()


def _step_maps(A, h: float):
    """Phi = e^{Ah}, J_0 and J_1 / h of :func:`foh_discretise` (shape of A each), read-only.

    They depend on A and h alone: the fits of a discover evaluate the same realisations' A with
    other inputs E again and again (a lag, a delay, a bank move E, not A), so the last few are
    kept, keyed on A's bytes (a hit returns the very arrays computed before: the same bits; the
    halvings are chosen from the whole stack's largest norm, so only the same stack may hit).
    """
    key = (A.shape, float(h), A.tobytes()) if A.nbytes <= _STEP_MAPS_BYTES else None
    if key is not None:
        with _STEP_MAPS_LOCK:
            maps = _STEP_MAPS.get(key)
            if maps is not None:
                _STEP_MAPS.move_to_end(key)
                return maps
    # Scaling and squaring of e^{Ah}, J_0 = int_0^h e^{As} ds and J_1 = int_0^h e^{As} (h - s) ds
    # on d x d matrices (Van Loan's 3d x 3d block costs 27 times the arithmetic per product):
    # Taylor series at h / 2^s, then per doubling of the step
    # J_1(2h) = (I + Phi) J_1 + h J_0, J_0(2h) = (I + Phi) J_0, Phi(2h) = Phi^2.
    X, rho, s = _scaled(A, h)
    hs = h / 2.0**s
    Phi, phi1, phi2 = _phi_functions_taylor(X, rho)
    J0, J1 = phi1 * hs, phi2 * (hs * hs)
    for _ in range(s):
        J1 = J1 + Phi @ J1 + hs * J0
        J0 = J0 + Phi @ J0
        Phi = Phi @ Phi
        hs *= 2.0
    maps = (Phi, J0, J1 / h)
    for a in maps:
        a.setflags(write=False)
    if key is not None:
        with _STEP_MAPS_LOCK:
            _STEP_MAPS[key] = maps
            while len(_STEP_MAPS) > _STEP_MAPS_ENTRIES:
                _STEP_MAPS.popitem(last=False)
    return maps


#: Largest 1-norm of A h / 2^s at which :func:`foh_discretise` sums the Taylor series.
_PHI_TAYLOR_NORM = 0.5


def _scaled(A, h: float):
    """A h / 2^s, its 1-norm bound and the number s of doublings that bring the norm to at most
    :data:`_PHI_TAYLOR_NORM` (the largest over a stack)."""
    X = A * h
    rho = np.abs(X).sum(axis=-2).max() if X.size else 0.0
    s = max(0, int(np.ceil(np.log2(rho / _PHI_TAYLOR_NORM)))) if rho > _PHI_TAYLOR_NORM else 0
    return X / 2.0**s, rho / 2.0**s, s


def _phi_functions_taylor(X, rho: float):
    """e^X, phi_1(X) = sum X^k / (k+1)! and phi_2(X) = sum X^k / (k+2)! of a stack of matrices
    whose 1-norms are at most ``rho`` <= 1, by their Taylor series.

    With X = A h, Van Loan's exponential holds J_0 = h phi_1(X) and J_1 = h^2 phi_2(X) (Higham,
    Functions of Matrices, sec. 10.7). The series is cut at the first degree N with
    rho^(N+1) / (N+1)! < 1e-17 (the remainder of each series is below that times e^rho), i.e.
    N <= 13 for rho <= 0.5: below the rounding of double precision.

    Parameters
    ----------
    X : ndarray, shape (..., d, d)
    rho : float
        Upper bound of the 1-norms of X.

    Returns
    -------
    expX, phi1, phi2 : ndarray, shape (..., d, d)
    """
    eye = np.broadcast_to(np.eye(X.shape[-1]), X.shape)
    expX, phi1, phi2 = eye + X, eye + X / 2.0, eye / 2.0 + X / 6.0
    term, k, bound = X, 1, rho * rho / 2.0
    while bound > 1e-17 and k < 30:
        k += 1
        term = (term @ X) / k  # X^k / k!
        bound *= rho / (k + 1)  # rho^(k+1) / (k+1)!, the first term left out
        expX = expX + term
        phi1 = phi1 + term / (k + 1)
        phi2 = phi2 + term / ((k + 1) * (k + 2))
    return expX, phi1, phi2


def foh_discretise_derivatives(A, E, h: float, dA, dE):
    """:func:`foh_discretise` of one system with the exact derivatives of Phi, P and Q along
    directions (dA_p, dE_p) of its matrices (forward mode through the series and the doublings).

    The sensitivity of x' = A x + E g obeys s_p' = A s_p + dA_p x + dE_p g, so dPhi_p, dP_p, dQ_p
    are the lower blocks of the maps of the block-triangular system [[A, 0], [dA_p, A]] with
    inputs [E; dE_p]. Products of such matrices keep their diagonal blocks, so each Taylor term
    and each doubling of :func:`foh_discretise` is carried with its derivative: two d x d products
    per direction instead of the eight of the 2d x 2d system, and the number of doublings is set
    by A alone (a direction far larger than A costs no accuracy). Directions with dA_p = 0 (the
    wind bounds) need no derivative of Phi, J_0, J_1 at all.

    Parameters
    ----------
    A : ndarray, shape (d, d)
    E : ndarray, shape (d, r)
    h : float
        Step (s).
    dA : ndarray, shape (p, d, d)
    dE : ndarray, shape (p, d, r)

    Returns
    -------
    (Phi, P, Q) as :func:`foh_discretise`, and (dPhi, dP, dQ) with shapes (p, d, d), (p, d, r),
    (p, d, r).
    """
    A, E = np.asarray(A, float), np.asarray(E, float)
    dA, dE = np.asarray(dA, float), np.asarray(dE, float)
    d, r = E.shape
    n_p = dA.shape[0]
    X, rho, s = _scaled(A, h)
    hs = h / 2.0**s
    moving = np.flatnonzero(np.any(dA.reshape(n_p, -1) != 0, axis=1)) if n_p else np.zeros(0, int)
    (Phi, phi1, phi2), (dPhi, dphi1, dphi2) = _phi_functions_taylor_derivatives(X, dA[moving] * hs, rho)
    J0, J1 = phi1 * hs, phi2 * (hs * hs)
    dJ0, dJ1 = dphi1 * hs, dphi2 * (hs * hs)
    for _ in range(s):
        dJ1 = dJ1 + dPhi @ J1 + Phi @ dJ1 + hs * dJ0
        J1 = J1 + Phi @ J1 + hs * J0
        dJ0 = dJ0 + dPhi @ J0 + Phi @ dJ0
        J0 = J0 + Phi @ J0
        dPhi = dPhi @ Phi + Phi @ dPhi
        Phi = Phi @ Phi
        hs *= 2.0
    Q = (J1 / h) @ E
    P = J0 @ E - Q
    dQ = (J1 / h) @ dE
    dP = J0 @ dE - dQ
    dQ_moving = (dJ1 / h) @ E
    dQ[moving] += dQ_moving
    dP[moving] += dJ0 @ E - dQ_moving
    dPhi_all = np.zeros((n_p, d, d))
    dPhi_all[moving] = dPhi
    return (Phi, P, Q), (dPhi_all, dP, dQ)


def _phi_functions_taylor_derivatives(X, D, rho: float):
    """:func:`_phi_functions_taylor` of one matrix X (d, d) with the derivatives of e^X, phi_1 and
    phi_2 along the directions D (p, d, d): d(X^k / k!) = (d(X^(k-1) / (k-1)!) X + X^(k-1) / (k-1)! D) / k.
    The series runs one term past the values' cut, as the derivative's remainder is
    (N + 2) / rho times the values' bound."""
    eye = np.eye(X.shape[-1])
    expX, phi1, phi2 = eye + X, eye + X / 2.0, eye / 2.0 + X / 6.0
    dexp, dphi1, dphi2 = D.copy(), D / 2.0, D / 6.0
    term, dterm, k, bound = X, D, 1, rho * rho / 2.0
    while (bound * (k + 2) / max(rho, 1e-300) > 1e-17) and k < 30:
        k += 1
        dterm = (dterm @ X + term @ D) / k
        term = (term @ X) / k
        bound *= rho / (k + 1)
        expX = expX + term
        phi1 = phi1 + term / (k + 1)
        phi2 = phi2 + term / ((k + 1) * (k + 2))
        dexp = dexp + dterm
        dphi1 = dphi1 + dterm / (k + 1)
        dphi2 = dphi2 + dterm / ((k + 1) * (k + 2))
    return (expX, phi1, phi2), (dexp, dphi1, dphi2)


def foh_discretise_derivatives_batched(A, E, h: float, dA, dE):
    """:func:`foh_discretise_derivatives` of a stack of systems, one NumPy call per series term
    and doubling for the whole stack (e.g. the steps of a time-varying system).

    Parameters
    ----------
    A : ndarray, shape (K, d, d)
    E : ndarray, shape (K, d, r)
    h : float
        Step (s).
    dA : ndarray, shape (K, p, d, d)
    dE : ndarray, shape (K, p, d, r)

    Returns
    -------
    (Phi, P, Q) with shapes (K, d, d), (K, d, r), (K, d, r), and (dPhi, dP, dQ) with a p axis
    after K.
    """
    A, E = np.asarray(A, float), np.asarray(E, float)
    dA, dE = np.asarray(dA, float), np.asarray(dE, float)
    K, n_p, d = dA.shape[0], dA.shape[1], A.shape[-1]
    X, rho, s = _scaled(A, h)
    hs = h / 2.0**s
    moving = np.flatnonzero(np.any(dA != 0, axis=(0, 2, 3)))  # directions that move A (not the wind's)
    D = dA[:, moving] * hs
    Xb = X[:, None]
    eye = np.eye(X.shape[-1])
    Phi, phi1, phi2 = eye + X, eye + X / 2.0, eye / 2.0 + X / 6.0
    dPhi, dphi1, dphi2 = D.copy(), D / 2.0, D / 6.0
    term, dterm, k, bound = X, D, 1, rho * rho / 2.0
    while (bound * (k + 2) / max(rho, 1e-300) > 1e-17) and k < 30:
        k += 1
        dterm = (dterm @ Xb + term[:, None] @ D) / k
        term = (term @ X) / k
        bound *= rho / (k + 1)
        Phi, phi1, phi2 = Phi + term, phi1 + term / (k + 1), phi2 + term / ((k + 1) * (k + 2))
        dPhi, dphi1, dphi2 = dPhi + dterm, dphi1 + dterm / (k + 1), dphi2 + dterm / ((k + 1) * (k + 2))
    J0, J1 = phi1 * hs, phi2 * (hs * hs)
    dJ0, dJ1 = dphi1 * hs, dphi2 * (hs * hs)
    for _ in range(s):
        Pb = Phi[:, None]
        dJ1 = dJ1 + dPhi @ J1[:, None] + Pb @ dJ1 + hs * dJ0
        J1 = J1 + Phi @ J1 + hs * J0
        dJ0 = dJ0 + dPhi @ J0[:, None] + Pb @ dJ0
        J0 = J0 + Phi @ J0
        dPhi = dPhi @ Pb + Pb @ dPhi
        Phi = Phi @ Phi
        hs *= 2.0
    Q = (J1 / h) @ E
    P = J0 @ E - Q
    dQ = (J1 / h)[:, None] @ dE
    dP = J0[:, None] @ dE - dQ
    dQ_moving = (dJ1 / h) @ E[:, None]
    dQ[:, moving] += dQ_moving
    dP[:, moving] += dJ0 @ E[:, None] - dQ_moving
    dPhi_all = np.zeros((K, n_p, d, d))
    dPhi_all[:, moving] = dPhi
    return (Phi, P, Q), (dPhi_all, dP, dQ)

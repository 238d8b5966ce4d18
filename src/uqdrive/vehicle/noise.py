"""Measurement-noise model of the thesis, eq. (5.6): s_c(t_k) = s(t_k) + A |s|_max zeta_k.

Noise is post-processing of a clean ensemble; nothing is re-simulated.
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from .single_track import STATES

__all__ = ["noise_scale", "add_noise", "added_noise_variance", "noisy_ensemble", "estimate_noise_variance"]


def noise_scale(signal, A: float):
    """Standard deviation of the noise added to each realisation's signal, A |s|_max (5.6).

    Parameters
    ----------
    signal : ndarray, shape (n, n_time)
        One state of n realisations, in that state's unit; |s|_max is taken over time for each realisation
        ("each individual signal" of sec. 5.1).
    A : float
        Noise intensity of Table 5.3.

    Returns
    -------
    ndarray, shape (n,)
    """
    return A * np.max(np.abs(signal), axis=-1)


def add_noise(signal, A: float, rng: np.random.Generator):
    """Corrupt ``signal`` (n, n_time) by (5.6) with zeta_k ~ N(0, 1) drawn from ``rng``."""
    signal = np.asarray(signal, float)
    zeta = rng.standard_normal(signal.shape)
    return signal + noise_scale(signal, A)[:, None] * zeta


def added_noise_variance(signal, A: float, mask=None) -> float:
    """Variance that (5.6) adds to the ensemble at every time: A^2 E_j[|s_j|_max^2].

    Parameters
    ----------
    signal : ndarray, shape (n, n_time)
        One state of n realisations, in that state's unit.
    A : float
    mask : ndarray of bool, shape (n,), optional
        Realisations that enter the statistics.
    """
    scale = noise_scale(signal, A)
    if mask is not None:
        scale = scale[mask]
    return float(np.mean(scale**2))


def noisy_ensemble(ds: xr.Dataset, A: float, rng: np.random.Generator) -> xr.Dataset:
    """Copy of a clean ensemble with every state corrupted by (5.6); ``noise_A`` attribute set."""
    if ds.attrs.get("noise_A", 0.0) != 0.0:
        raise ValueError("noise is added to a clean ensemble (noise_A = 0) only")
    out = ds.copy()
    for name in STATES:
        out[name] = (ds[name].dims, add_noise(ds[name].values, A, rng), ds[name].attrs)
    out.attrs["noise_A"] = float(A)
    return out


def estimate_noise_variance(signal, dt_axis: int = -1, order: int = 2) -> float:
    """Variance of white measurement noise estimated from the data alone (no knowledge of A).

    Differences of order k cancel the smooth signal (for a 10 ms grid the vehicle states change by
    far less than the noise over k steps) while white noise of variance s^2 gives
    Var(d_k) = C(2k, k) s^2 (6 for k = 2, 70 for k = 4); the median absolute deviation makes the
    estimate robust to the fast transient at the start. Per realisation, then averaged:
    E_j[s_j^2], the variance that (5.6) adds to the ensemble. Order 2 is the thesis-era choice of
    the identification study; order 4 leaves the curvature of noise-free signals out of the
    estimate (the discrepancy workflow, whose null band resolves far smaller variances).

    Parameters
    ----------
    signal : ndarray, shape (n, n_time)
        One noisy state of n realisations, in that state's unit.
    order : int
        Order k of the differences.
    """
    from math import comb

    dk = np.diff(np.asarray(signal, float), n=order, axis=dt_axis)
    mad = np.median(np.abs(dk - np.median(dk, axis=dt_axis, keepdims=True)), axis=dt_axis)
    return float(np.mean((mad / 0.6744897501960817) ** 2 / comb(2 * order, order)))

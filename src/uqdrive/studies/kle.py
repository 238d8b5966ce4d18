"""The side-wind process as data: its KLE (eigenpairs, eigenfunctions) and realisations drawn
both from the KLE and directly from the covariance (thesis Figs 5.2 and 7.1).
"""

from __future__ import annotations

from typing import Any, Mapping

import numpy as np
import xarray as xr

from .._version import __version__
from ..config import config_hash
from ..vehicle.uncertainty import KarhunenLoeve, squared_exponential_covariance

__all__ = ["direct_samples", "kle_dataset"]


def direct_samples(t, Tc: float, n: int, rng: np.random.Generator) -> np.ndarray:
    """Draw n paths of the unit process with covariance (5.2) on the grid ``t`` directly.

    The squared-exponential covariance matrix is numerically singular, so it is factorised by
    its symmetric eigendecomposition with negative round-off eigenvalues clipped to zero.

    Returns
    -------
    ndarray, shape (n, len(t))
    """
    C = squared_exponential_covariance(t, t, Tc)
    lam, V = np.linalg.eigh(C)
    root = V * np.sqrt(np.clip(lam, 0.0, None))
    return rng.standard_normal((n, len(t))) @ root.T


def kle_dataset(config: Mapping[str, Any], kle: KarhunenLoeve, t, n_paths: int, rng: np.random.Generator) -> xr.Dataset:
    """Dataset of the KLE: eigenpairs, eigenfunctions on ``t`` and n KLE and direct sample paths."""
    Tc = config["wind"]["Tc"]
    return xr.Dataset(
        {
            "eigenvalue": ("kle_mode", kle.eigenvalues, {"units": "s"}),
            "eigenfunction": (("kle_mode", "time"), kle.eigenfunctions(t), {"units": "1/sqrt(s)"}),
            "all_eigenvalue": ("quadrature_node", kle.all_eigenvalues, {"units": "s", "long_name": "every Nystrom eigenvalue"}),
            "kle_sample": (("path", "time"), kle.realise(rng.standard_normal((n_paths, kle.n_modes)), t), {"units": "1"}),
            "direct_sample": (("path", "time"), direct_samples(t, Tc, n_paths, rng), {"units": "1"}),
        },
        coords={"time": ("time", np.asarray(t), {"units": "s"}), "kle_mode": np.arange(kle.n_modes)},
        attrs={
            "title": "Karhunen-Loeve expansion of the side-wind process",
            "Tc": float(Tc),
            "kle_quadrature": int(config["wind"]["kle_quadrature"]),
            "kle_truncation": float(config["wind"]["kle_truncation"]),
            "captured_variance": kle.captured_variance,
            "n_modes": kle.n_modes,
            "seed": int(config["seed"]),
            "config_hash": config_hash(config),
            "uqdrive_version": __version__,
        },
    )

"""PCE results as datasets for the report: moments and Sobol indices of the LST (thesis Figs 5.3,
5.4) and the convergence of the moments in N_PCE and quadrature order against Monte Carlo.
"""

from __future__ import annotations

import time
from typing import Any, Mapping, Sequence

import numpy as np
import xarray as xr

from .._version import __version__
from ..config import config_hash
from ..vehicle.chaos import ChaosMoments, LSTChaosModel
from ..vehicle.single_track import STATES
from ..settings import Settings

__all__ = ["pce_dataset", "convergence_study"]


def _provenance(config) -> dict:
    return {"seed": int(config["seed"]), "config_hash": config_hash(config), "uqdrive_version": __version__}


def pce_dataset(config: Mapping[str, Any], model: LSTChaosModel, moments: ChaosMoments) -> xr.Dataset:
    """Mean, std, first-order and total Sobol indices of every state over time."""
    names, first = model.sobol(moments)
    _, total = model.sobol(moments, total=True)
    coords = {"state": list(STATES), "time": ("time", moments.time, {"units": "s"}), "group": names}
    return xr.Dataset(
        {
            "mean": (("state", "time"), moments.mean, {"long_name": "PCE mean (4.51a)"}),
            "std": (("state", "time"), moments.std, {"long_name": "PCE standard deviation (4.51b)"}),
            "sobol_first": (("group", "state", "time"), first, {"long_name": "first-order Sobol index (4.76)"}),
            "sobol_total": (("group", "state", "time"), total, {"long_name": "total Sobol index (4.77)"}),
        },
        coords=coords,
        attrs={
            "title": "Galerkin PCE of the LST with all uncertainties",
            "order": model.projector.chaos.order,
            "n_terms": model.projector.n_terms,
            "germs": ", ".join(model.germ_names),
            "quadrature_nodes": int(model.projector.nodes.shape[0]),
            **_provenance(config),
        },
    )


def convergence_study(
    config: Mapping[str, Any],
    orders: Sequence[int],
    quadrature_points: Sequence[int],
    reference_mean,
    reference_std,
    reference_samples: int,
) -> xr.Dataset:
    """Moment errors of the full-uncertainty LST PCE for every (order, quadrature points) pair.

    Errors are max over time of |PCE - reference| divided by the state's largest reference std,
    for the mean and for the std. The reference's own standard errors (1 / sqrt(N) and
    1 / sqrt(2 (N - 1)) in the same units) are stored as the floor below which no error can be
    resolved.
    """
    ref_mean, ref_std = np.asarray(reference_mean), np.asarray(reference_std)
    scale = ref_std.max(axis=1)
    shape = (len(orders), len(quadrature_points), len(STATES))
    err_mean, err_std, seconds = np.full(shape, np.nan), np.full(shape, np.nan), np.full(shape[:2], np.nan)
    theta, settings = None, Settings.from_config(config)
    for i, order in enumerate(orders):
        for j, q in enumerate(quadrature_points):
            model = LSTChaosModel(settings, order=order, quadrature_points=q)
            theta = settings.uncertainty.theta(model.uncertain) if theta is None else theta
            t0 = time.perf_counter()
            r = model.moments(theta)
            seconds[i, j] = time.perf_counter() - t0
            err_mean[i, j] = np.abs(r.mean - ref_mean).max(axis=1) / scale
            err_std[i, j] = np.abs(r.std - ref_std).max(axis=1) / scale
    dims = ("order", "quadrature_points", "state")
    return xr.Dataset(
        {
            "mean_error": (dims, err_mean, {"long_name": "max_t |mean - reference| / max_t reference std"}),
            "std_error": (dims, err_std, {"long_name": "max_t |std - reference| / max_t reference std"}),
            "seconds": (dims[:2], seconds, {"units": "s", "long_name": "time of one moment evaluation"}),
            "reference_mean": (("state", "time"), ref_mean),
            "reference_std": (("state", "time"), ref_std),
        },
        coords={"order": list(orders), "quadrature_points": list(quadrature_points), "state": list(STATES)},
        attrs={
            "title": "PCE moment convergence against Monte Carlo",
            "reference_samples": int(reference_samples),
            "mean_floor": 1.0 / np.sqrt(reference_samples),
            "std_floor": 1.0 / np.sqrt(2.0 * (reference_samples - 1)),
            **_provenance(config),
        },
    )

"""Ensemble statistics under an explicit spin policy: mean and standard deviation of every state
over realisations, for clean and noise-corrupted data sets (thesis sec. 6.1, Figs 6.1-6.6).
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from ..numerics.metrics import kl_divergence_normal
from .noise import add_noise, added_noise_variance, estimate_noise_variance
from .channels import CHANNEL_UNITS
from .single_track import STATES

__all__ = ["SPIN_POLICIES", "used_samples", "ensemble_statistics", "noise_statistics", "kl_divergence_series"]

SPIN_POLICIES = ("keep", "exclude")


def used_samples(ds: xr.Dataset, policy: str) -> np.ndarray:
    """Boolean mask (sample,) of the realisations that enter statistics under ``policy``."""
    if policy not in SPIN_POLICIES:
        raise ValueError(f"unknown spin policy '{policy}'; choose keep or exclude")
    n = ds.sizes["sample"]
    if policy == "keep" or "spun" not in ds:
        return np.ones(n, dtype=bool)
    return ds["spun"].values == 0


def _stack_states(ds: xr.Dataset, mask, channels=STATES) -> np.ndarray:
    return np.stack([ds[s].values[mask] for s in channels])  # (state, n_used, time)


def _stats_dataset(mean, std, ds, mask, policy, extra_dims=(), extra_coords=None, channels=STATES) -> xr.Dataset:
    dims = extra_dims + ("state", "time")
    coords = {"state": list(channels), "time": ds["time"]}
    coords.update(extra_coords or {})
    attrs = {k: v for k, v in ds.attrs.items() if k not in ("title",)}
    attrs.update(
        {
            "title": f"ensemble statistics ({ds.attrs.get('model', 'measured')}, {ds.attrs.get('steer', '')})",
            "spin_policy": policy,
            "n_samples": int(mask.size),
            "n_used": int(mask.sum()),
            "n_spun_total": int(ds.attrs.get("n_spun", 0)),
            "state_units": ", ".join(f"{s}: {CHANNEL_UNITS[s]}" for s in channels),
        }
    )
    return xr.Dataset(
        {
            "mean": (dims, mean, {"long_name": "ensemble mean (units of each state)"}),
            "std": (dims, std, {"long_name": "ensemble standard deviation, ddof=1 (units of each state)"}),
        },
        coords=coords,
        attrs=attrs,
    )


def ensemble_statistics(ds: xr.Dataset, policy: str = "exclude", channels=STATES) -> xr.Dataset:
    """Mean and sample standard deviation of every state (or of ``channels``, names of
    :data:`uqdrive.vehicle.channels.CHANNELS`) over the used realisations.

    Returns
    -------
    xarray.Dataset
        Variables ``mean`` and ``std`` with dims (state, time); attributes record the policy
        and how many realisations were used and excluded.
    """
    mask = used_samples(ds, policy)
    x = _stack_states(ds, mask, channels)
    return _stats_dataset(x.mean(axis=1), x.std(axis=1, ddof=1), ds, mask, policy, channels=tuple(channels))


def noise_statistics(ds: xr.Dataset, levels, rngs, policy: str = "exclude") -> xr.Dataset:
    """Statistics of the noise-corrupted data sets of Table 5.3, one per level, dims (noise, state, time).

    Parameters
    ----------
    ds : xarray.Dataset
        Clean ensemble.
    levels : sequence of float
        Noise intensities A.
    rngs : sequence of numpy.random.Generator
        One generator per level (so a level's data do not depend on the other levels).
    """
    mask = used_samples(ds, policy)
    means, stds, est, true = [], [], [], []
    for A, rng in zip(levels, rngs):
        noisy = np.stack([add_noise(ds[s].values, A, rng)[mask] for s in STATES])
        means.append(noisy.mean(axis=1))
        stds.append(noisy.std(axis=1, ddof=1))
        est.append([estimate_noise_variance(noisy[i]) for i in range(len(STATES))])
        true.append([added_noise_variance(ds[s].values, A, mask) for s in STATES])
    out = _stats_dataset(
        np.stack(means), np.stack(stds), ds, mask, policy, ("noise",), {"noise": ("noise", np.asarray(levels, float), {"long_name": "noise intensity A (5.6)"})}
    )
    out["noise_variance"] = (("noise", "state"), np.array(est), {"long_name": "noise variance estimated from the data (second differences)"})
    out["noise_variance_true"] = (("noise", "state"), np.array(true), {"long_name": "variance added by (5.6), A^2 E[max|s|^2]"})
    out.attrs["title"] = f"noise-corrupted ensemble statistics ({ds.attrs.get('model', 'measured')})"
    return out


def kl_divergence_series(p: xr.Dataset, q: xr.Dataset) -> xr.DataArray:
    """D_KL(P || Q) of the per-time normal approximations of two statistics datasets (Fig 6.6)."""
    kl = kl_divergence_normal(p["mean"].values, p["std"].values, q["mean"].values, q["std"].values)
    return xr.DataArray(kl, coords=p["mean"].coords, dims=p["mean"].dims, name="kl_divergence", attrs={"units": "nat"})

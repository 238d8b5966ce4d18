"""Figures of the emcee cross-check: corner plots with 68 % and 95 % levels, traces per ensemble."""

from __future__ import annotations

import corner
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import xarray as xr  # noqa: E402

from ..studies.bayes import summarise  # noqa: E402

__all__ = ["corner_plot", "trace_plot"]


def corner_plot(ds: xr.Dataset, title: str):
    """Posterior of all ensembles (after burn-in and thinning); truth (blue) and optimiser (red)."""
    s = summarise(ds)
    pooled = []
    for e in range(ds.sizes["ensemble"]):
        c = ds["chain"].values[e][int(ds["burn"][e]) :: int(ds["thin"][e])]
        pooled.append(c[np.all(np.isfinite(c), axis=(1, 2))].reshape(-1, ds.sizes["parameter"]))
    samples = np.concatenate(pooled)
    fig = corner.corner(samples, labels=list(ds["parameter"].values), levels=(0.68, 0.95), truths=np.asarray(ds.attrs["truth"]),
                        quantiles=(0.025, 0.975), show_titles=False)
    corner.overplot_points(fig, np.asarray(ds.attrs["optimiser_estimate"])[None, :], marker="s", color="C3")
    fig.suptitle(f"{title}: {s['samples']} posterior samples (blue: truth, red: optimiser)", y=1.02)
    return fig


def trace_plot(ds: xr.Dataset, title: str):
    """Walker traces of every parameter, one colour per ensemble, burn-in shaded."""
    p = ds.sizes["parameter"]
    fig, axes = plt.subplots(p, 1, figsize=(10, 1.6 * p), sharex=True, constrained_layout=True)
    for j, ax in enumerate(axes):
        for e in range(ds.sizes["ensemble"]):
            ax.plot(ds["chain"].values[e, :, :, j], color=f"C{e}", lw=0.3, alpha=0.4)
            ax.axvspan(0, int(ds["burn"][e]), color="0.9", zorder=-1)
        ax.set_ylabel(str(ds["parameter"].values[j]), fontsize=8)
    axes[-1].set_xlabel("step")
    fig.suptitle(f"{title}: tau max {np.nanmax(ds['tau'].values):.0f}, R-hat max {np.nanmax(ds['r_hat'].values):.3f}")
    return fig

"""Figures of the lane-keeping test case: Figs 6.16-6.18 (PCE and Monte Carlo closed loops with
the LQR and the SLQR) and the gamma sweep of the SLQR.
"""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import xarray as xr  # noqa: E402

from ..vehicle.single_track import STATE_NAMES, STATE_UNITS, STATES  # noqa: E402

__all__ = ["closed_loop_bands", "gamma_sweep_figure"]


def closed_loop_bands(title: str, pce: xr.Dataset | None, mc: xr.Dataset | None, controllers, band: float = 3.0):
    """Mean +- band std of every state and of the steering, from PCE (lines) and Monte Carlo (shaded)."""
    fig, axes = plt.subplots(2, 3, figsize=(14, 7), constrained_layout=True)
    axes = axes.ravel()
    for c_i, name in enumerate(controllers):
        colour = f"C{c_i}"
        for ax, state in zip(axes, list(STATES) + ["delta"]):
            if mc is not None and name in mc["controller"].values:
                x = mc[state].sel(controller=name).values
                t = mc["time"].values
                m, s = x.mean(axis=0), x.std(axis=0, ddof=1)
                ax.fill_between(t, m - band * s, m + band * s, color=colour, alpha=0.2)
                ax.plot(t, m, color=colour, lw=1.0, label=f"{name} MC")
            if pce is not None and name in pce["controller"].values:
                t = pce["time"].values
                if state == "delta":
                    m, v = pce["u_mean"].sel(controller=name).values, pce["u_variance"].sel(controller=name).values
                else:
                    m, v = pce["mean"].sel(controller=name, state=state).values, pce["variance"].sel(controller=name, state=state).values
                s = np.sqrt(np.maximum(v, 0))
                ax.plot(t, m, "--", color=colour, lw=1.2, label=f"{name} PCE")
                ax.plot(t, m + band * s, ":", color=colour, lw=0.8)
                ax.plot(t, m - band * s, ":", color=colour, lw=0.8)
    for ax, state in zip(axes, list(STATES) + ["delta"]):
        unit = STATE_UNITS.get(state, "rad")
        ax.set(title=STATE_NAMES.get(state, "steering angle u = K x"), xlabel="time [s]", ylabel=f"{state} [{unit}]")
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=7)
    axes[-1].axis("off")
    fig.suptitle(title + f" (mean +- {band:g} std)")
    return fig


def gamma_sweep_figure(ds: xr.Dataset):
    """Mean and variance parts of the cost against gamma, beside the LQR's."""
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(11, 4), constrained_layout=True)
    g = ds["gamma"].values
    ax.plot(g, ds["mean_cost"], "o-", label="SLQR mean part")
    ax.axhline(ds.attrs["lqr_mean_cost"], color="k", ls="--", label="LQR")
    bx.plot(g, ds["variance_cost"], "o-", label="SLQR variance part")
    bx.axhline(ds.attrs["lqr_variance_cost"], color="k", ls="--", label="LQR")
    for a, title in ((ax, "cost of the mean trajectory"), (bx, "cost of the variance")):
        a.set(xscale="log", xlabel="gamma", title=title)
        a.grid(alpha=0.3, which="both")
        a.legend()
    fig.suptitle("SLQR gamma sweep: sum_t x'(Q + K'RK)x over the mean and the variance terms")
    return fig

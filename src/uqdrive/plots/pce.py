"""Figures of the polynomial chaos engine: PCE against Monte Carlo, Sobol indices and the
convergence study (thesis Figs 5.3, 5.4).
"""

from __future__ import annotations

import matplotlib.pyplot as plt
import xarray as xr

from ..vehicle.single_track import STATE_NAMES, STATES
from .figure import label_state, state_axes, time_axis

__all__ = ["pce_vs_monte_carlo", "sobol_indices", "pce_convergence"]


def pce_vs_monte_carlo(pce: xr.Dataset, mc: xr.Dataset, band_sigmas: float = 3.0):
    """Thesis Fig 5.3: PCE and Monte Carlo mean and mean +- k std of every state."""
    fig, axes = state_axes(title=f"PCE (N_PCE = {pce.attrs['order']}) vs Monte Carlo ({mc.attrs['n_used']} runs)")
    t = pce["time"].values
    for ax, state in zip(axes, STATES):
        for ds, name, colour, style in ((mc, "Monte Carlo", "C0", "-"), (pce, "PCE", "C1", "--")):
            m, s = ds["mean"].sel(state=state).values, ds["std"].sel(state=state).values
            ax.plot(t, m, style, color=colour, lw=1.2, label=f"{name} mean")
            ax.plot(t, m + band_sigmas * s, style, color=colour, lw=0.7, label=f"{name} +- {band_sigmas:g} std")
            ax.plot(t, m - band_sigmas * s, style, color=colour, lw=0.7)
        label_state(ax, state)
    axes[0].legend(fontsize=7)
    return time_axis(fig, axes)


def sobol_indices(pce: xr.Dataset):
    """Thesis Fig 5.4: first-order Sobol indices of every state over time, per uncertainty."""
    fig, axes = state_axes(title="First-order sensitivity to each uncertainty")
    t = pce["time"].values
    for ax, state in zip(axes, STATES):
        for g in pce["group"].values:
            ax.plot(t, pce["sobol_first"].sel(group=g, state=state).values, lw=1.0, label=str(g))
        ax.set_ylim(-0.02, 1.02)
        ax.set_ylabel("S_1 [-]")
        ax.set_title(STATE_NAMES[state])
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=7)
    return time_axis(fig, axes)


def pce_convergence(conv: xr.Dataset):
    """Moment error of the PCE against the Monte Carlo reference over N_PCE and quadrature."""
    fig, axes = plt.subplots(1, 2, figsize=(11, 4), sharey=True, constrained_layout=True)
    for ax, var, floor, title in ((axes[0], "mean_error", "mean_floor", "mean"), (axes[1], "std_error", "std_floor", "standard deviation")):
        worst = conv[var].max("state")
        for q in conv["quadrature_points"].values:
            ax.semilogy(conv["order"].values, worst.sel(quadrature_points=q).values, "o-", label=f"{q} Gauss points")
        ax.axhline(2 * conv.attrs[floor], color="k", ls=":", label="2 SE of the reference")
        ax.set(xlabel="N_PCE", title=f"error of the {title} (worst state)")
        ax.set_xticks(conv["order"].values)
        ax.grid(alpha=0.3, which="both")
    axes[0].set_ylabel("max_t |PCE - MC| / max_t std")
    axes[1].legend(fontsize=8)
    fig.suptitle(f"PCE convergence against {conv.attrs['reference_samples']} Monte Carlo runs")
    return fig

"""Figures of the data synthesis: tyre curves, the wind KLE, ensemble bands, noise levels,
LST vs NLST and their KL divergence (thesis Figs 2.3, 5.2, 6.1-6.6, 7.1, A.1-A.22).
"""

from __future__ import annotations

from typing import Mapping

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr

from ..vehicle.single_track import STATE_NAMES, STATE_UNITS, STATES, magic_formula
from .figure import label_state, save_figure, state_axes, time_axis

__all__ = ["save_figure", "tyre_curves", "kle_realisations", "ensemble_band", "noise_levels", "lst_vs_nlst",
           "kl_divergence", "kle_eigenfunctions"]


def tyre_curves(surfaces: Mapping[str, Mapping[str, float]]):
    """Thesis Fig 2.3: normalised longitudinal and lateral Magic-Formula forces per surface."""
    fig, (ax_x, ax_y) = plt.subplots(1, 2, figsize=(10, 4), constrained_layout=True)
    kappa = np.linspace(-1, 1, 801)
    alpha = np.deg2rad(np.linspace(-30, 30, 801))
    for name, c in surfaces.items():
        ax_x.plot(kappa, magic_formula(kappa, 1.0, c["B"], c["C"], c["D"], c["E"]), label=name)
        ax_y.plot(np.rad2deg(alpha), magic_formula(alpha, 1.0, c["B"], c["C"], c["D"], c["E"]), label=name)
    ax_x.set(xlabel="slip ratio kappa [-]", ylabel="F_x / F_z [-]", title="pure acceleration")
    ax_y.set(xlabel="slip angle alpha [deg]", ylabel="F_y / F_z [-]", title="pure steering")
    for ax in (ax_x, ax_y):
        ax.grid(alpha=0.3)
        ax.legend()
    return fig


def kle_realisations(kle_ds: xr.Dataset):
    """Thesis Fig 5.2: KLE realisations beside direct samples of the covariance (5.2)."""
    fig, axes = plt.subplots(1, 2, figsize=(11, 4), sharey=True, constrained_layout=True)
    t = kle_ds["time"].values
    axes[0].plot(t, kle_ds["direct_sample"].values.T, lw=0.8)
    axes[0].set_title("direct sampling of the covariance")
    axes[1].plot(t, kle_ds["kle_sample"].values.T, lw=0.8)
    axes[1].set_title(f"KLE, {kle_ds.sizes['kle_mode']} modes, p_c = {kle_ds.attrs['kle_truncation']}")
    for ax in axes:
        ax.set_xlabel("time [s]")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("F_w,alpha [-] (unit variance)")
    return fig


def ensemble_band(stats: xr.Dataset, band_sigmas: float = 3.0, title: str = "", noise_index: int | None = None):
    """Thesis Figs 6.1, 6.2, A.1-A.22: mean and mean +- k std of every state over time."""
    if noise_index is not None:
        stats = stats.isel(noise=noise_index)
    fig, axes = state_axes(title=title)
    t = stats["time"].values
    for ax, state in zip(axes, STATES):
        m = stats["mean"].sel(state=state).values
        s = stats["std"].sel(state=state).values
        ax.fill_between(t, m - band_sigmas * s, m + band_sigmas * s, alpha=0.3, label=f"mean +- {band_sigmas:g} std")
        ax.plot(t, m, lw=1.2, label="mean")
        label_state(ax, state)
    axes[0].legend(loc="upper right", fontsize=8)
    return time_axis(fig, axes)


def noise_levels(noise_stats: xr.Dataset, title: str = ""):
    """Thesis Figs 6.3/6.4: mean and variance of every state for each noise intensity A."""
    fig, axes = plt.subplots(4, 2, figsize=(11, 10), sharex=True, constrained_layout=True)
    if title:
        fig.suptitle(title)
    t = noise_stats["time"].values
    levels = noise_stats["noise"].values
    colours = plt.cm.viridis(np.linspace(0, 1, len(levels)))
    for i, state in enumerate(STATES):
        for j, A in enumerate(levels):
            sel = noise_stats.sel(state=state).isel(noise=j)
            axes[i, 0].plot(t, sel["mean"].values, color=colours[j], lw=0.9, label=f"A = {A:g}")
            axes[i, 1].plot(t, sel["std"].values ** 2, color=colours[j], lw=0.9)
        axes[i, 0].set_ylabel(f"{state} [{STATE_UNITS[state]}]")
        axes[i, 0].set_title(f"mean of {STATE_NAMES[state]}")
        axes[i, 1].set_title(f"variance of {STATE_NAMES[state]}")
        for ax in axes[i]:
            ax.grid(alpha=0.3)
    axes[0, 0].legend(fontsize=7, ncol=2)
    for ax in axes[-1]:
        ax.set_xlabel("time [s]")
    return fig


def lst_vs_nlst(stats_lst: xr.Dataset, stats_nlst: xr.Dataset, band_sigmas: float = 3.0):
    """Thesis Fig 6.5: LST and NLST outputs (mean +- k std) on common axes."""
    fig, axes = state_axes(title="LST vs NLST, noiseless data")
    t = stats_lst["time"].values
    for stats, name, colour in ((stats_lst, "LST", "C0"), (stats_nlst, "NLST", "C3")):
        for ax, state in zip(axes, STATES):
            m = stats["mean"].sel(state=state).values
            s = stats["std"].sel(state=state).values
            ax.fill_between(t, m - band_sigmas * s, m + band_sigmas * s, color=colour, alpha=0.2)
            ax.plot(t, m, color=colour, lw=1.2, label=f"{name} mean +- {band_sigmas:g} std")
    for ax, state in zip(axes, STATES):
        label_state(ax, state)
    axes[0].legend(fontsize=8)
    return time_axis(fig, axes)


def kl_divergence(kl: xr.Dataset):
    """Thesis Fig 6.6: D_KL(NLST || LST) of every state's per-time normal distribution."""
    fig, axes = state_axes(title="Kullback-Leibler divergence D_KL(NLST || LST)")
    t = kl["time"].values
    for ax, state in zip(axes, STATES):
        ax.plot(t, kl["kl_divergence"].sel(state=state).values, lw=1.0)
        ax.set_yscale("log")
        ax.set_ylabel("D_KL [nat]")
        ax.set_title(STATE_NAMES[state])
        ax.grid(alpha=0.3, which="both")
    return time_axis(fig, axes)


def kle_eigenfunctions(kle_ds: xr.Dataset):
    """Thesis Fig 7.1: the retained KLE eigenfunctions over the expansion interval."""
    fig, ax = plt.subplots(figsize=(9, 4), constrained_layout=True)
    t = kle_ds["time"].values
    for i, lam in enumerate(kle_ds["eigenvalue"].values):
        ax.plot(t, kle_ds["eigenfunction"].values[i], label=f"f_{i + 1}, lambda = {lam:.3f} s")
    ax.set(xlabel="time [s]", ylabel="f_n(t) [1/sqrt(s)]", title="KLE eigenfunctions of the side-wind process")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    return fig

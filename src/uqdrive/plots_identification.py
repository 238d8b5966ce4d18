"""Figures of the identification experiments: normalised W2 per run (Figs 6.7, 6.8), against
initial-guess deviation (6.11, 6.12) and noise (6.13, 6.14), identified distributions (6.9, 6.15,
B.1-B.13), tyre curves (6.10), robust starts and noise-aware estimation.
"""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import xarray as xr  # noqa: E402
from scipy.stats import norm  # noqa: E402

from .vehicle import VehicleParameters, magic_formula  # noqa: E402

__all__ = ["w2_per_run", "w2_against", "distributions", "tyre_curves_estimated"]

LABELS = {"mu": "friction mu", "l_f": "CoG to front axle l_f [m]", "F_w_mean": "mean side wind [N]"}


def w2_per_run(ds: xr.Dataset, estimates, title: str):
    """Figs 6.7/6.8: normalised W2 of each identified distribution for every run."""
    fig, axes = plt.subplots(1, 3, figsize=(13, 4), sharey=False, constrained_layout=True)
    runs = ds["run"].values
    width = 0.8 / len(estimates)
    for ax, dist in zip(axes, ds["distribution"].values):
        for k, est in enumerate(estimates):
            ax.bar(runs + (k - (len(estimates) - 1) / 2) * width, ds["w2"].sel(estimate=est, distribution=dist), width, label=est)
        if dist == "F_w_mean":
            for k, est in enumerate(estimates):
                ax.plot(runs + (k - (len(estimates) - 1) / 2) * width, ds["w2_thesis"].sel(estimate=est, distribution=dist), "k_", ms=8)
        ax.set(title=LABELS[str(dist)], xlabel="run", ylabel="normalised W2")
        ax.set_xticks(runs)
        ax.grid(alpha=0.3, axis="y")
    axes[0].legend(fontsize=8)
    fig.suptitle(title + "   (black ticks: thesis' printed (5.31))")
    return fig


def w2_against(ds: xr.Dataset, x, xlabel: str, estimates, title: str):
    """Figs 6.11-6.14 and the robust-start / noise-aware figures: W2 against a varied setting."""
    fig, axes = plt.subplots(1, 3, figsize=(13, 4), constrained_layout=True)
    for ax, dist in zip(axes, ds["distribution"].values):
        for est in estimates:
            style = "--" if ("aware" in est or "multi" in est) else "-"
            ax.plot(x, ds["w2"].sel(estimate=est, distribution=dist), "o" + style, label=est)
        ax.set(title=LABELS[str(dist)], xlabel=xlabel, ylabel="normalised W2")
        ax.set_yscale("log")
        ax.grid(alpha=0.3, which="both")
    axes[0].legend(fontsize=7)
    fig.suptitle(title)
    return fig


def distributions(ds: xr.Dataset, estimate: str, title: str):
    """Figs 6.9, 6.15, B.1-B.13: identified distributions of every run against the truth."""
    fig, axes = plt.subplots(1, 3, figsize=(13, 3.8), constrained_layout=True)
    th = ds["theta"].sel(estimate=estimate).values  # (run, 6)
    truth = ds["truth"].values
    spans = [(0.0, 2.0), (0.6, 2.5), (-1200.0, 1200.0)]
    for j, (ax, dist) in enumerate(zip(axes, ds["distribution"].values)):
        x = np.linspace(*spans[j], 600)
        for r in range(th.shape[0]):
            a, b = th[r, 2 * j], th[r, 2 * j + 1]
            if not np.all(np.isfinite([a, b])):
                continue
            y = norm.pdf(x, a, max(abs(b), 1e-6)) if j < 2 else ((x >= min(a, b)) & (x <= max(a, b))) / max(abs(b - a), 1e-9)
            ax.plot(x, y, color="C0", lw=0.8, alpha=0.7, label="estimates" if r == 0 else None)
        a, b = truth[2 * j], truth[2 * j + 1]
        y = norm.pdf(x, a, b) if j < 2 else ((x >= a) & (x <= b)) / (b - a)
        ax.plot(x, y, "k", lw=2, label="true")
        ax.set(title=LABELS[str(dist)], ylabel="density")
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.suptitle(title)
    return fig


def tyre_curves_estimated(config, mu_estimates: dict):
    """Fig 6.10: front tyre force of the non-linear model, its ideal linearisation, and the
    linear tyres of the identified mean frictions."""
    p = VehicleParameters.from_config(config)
    alpha = np.deg2rad(np.linspace(0, 10, 400))
    fig, ax = plt.subplots(figsize=(7, 4), constrained_layout=True)
    ax.plot(np.rad2deg(alpha), magic_formula(alpha, p.F_fz, p.c_Sf, p.C, 1.0, p.E), "k", lw=2, label="Magic Formula, mu = 1")
    ax.plot(np.rad2deg(alpha), p.c_f * alpha, "k--", label="ideal linearisation F_z B C D alpha")
    for label, mu in mu_estimates.items():
        ax.plot(np.rad2deg(alpha), p.c_f * mu * alpha, label=f"{label}: mu = {mu:.3f}")
    ax.set(xlabel="front slip angle [deg]", ylabel="front lateral force [N]", ylim=(0, 1.6 * p.F_fz))
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    return fig

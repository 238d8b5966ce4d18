"""Figures of the identification experiments: normalised W2 per run (Figs 6.7, 6.8), against
initial-guess deviation (6.11, 6.12) and noise (6.13, 6.14), identified distributions (6.9, 6.15,
B.1-B.13), tyre curves (6.10), robust starts and noise-aware estimation; and the plan of which
figure shows which experiment and estimate (:func:`identification_figures`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Iterator, Mapping, Sequence

import matplotlib
from ..settings import Settings

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import xarray as xr  # noqa: E402

from ..studies.experiments import APPENDIX_B_PLAN, FIGURE_NAMES, NLST_ESTIMATES  # noqa: E402
from ..vehicle.single_track import VehicleParameters, magic_formula  # noqa: E402

__all__ = ["NLST_ESTIMATES", "FIGURE_NAMES", "APPENDIX_B_PLAN", "w2_per_run", "w2_against", "distributions", "tyre_curves_estimated", "identification_figures"]

def _normal_pdf(x, mean: float, std: float):
    """Density of N(mean, std^2) at x (scipy.stats would add 0.8 s to the figure job's start)."""
    z = (np.asarray(x, float) - mean) / std
    return np.exp(-0.5 * z * z) / (std * np.sqrt(2.0 * np.pi))


LABELS = {"mu": "friction mu", "l_f": "CoG to front axle l_f [m]", "F_w_mean": "mean side wind [N]"}
#: Units of a probability density over each identified quantity (mu is dimensionless).
DENSITY_UNITS = {"mu": "-", "l_f": "1/m", "F_w_mean": "1/N"}


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
            y = _normal_pdf(x, a, max(abs(b), 1e-6)) if j < 2 else ((x >= min(a, b)) & (x <= max(a, b))) / max(abs(b - a), 1e-9)
            ax.plot(x, y, color="C0", lw=0.8, alpha=0.7, label="estimates" if r == 0 else None)
        a, b = truth[2 * j], truth[2 * j + 1]
        y = _normal_pdf(x, a, b) if j < 2 else ((x >= a) & (x <= b)) / (b - a)
        ax.plot(x, y, "k", lw=2, label="true")
        ax.set(title=LABELS[str(dist)], xlabel=LABELS[str(dist)].replace("friction mu", "mu [-]"),
               ylabel=f"density [{DENSITY_UNITS[str(dist)]}]")
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.suptitle(title)
    return fig


def tyre_curves_estimated(config, mu_estimates: dict):
    """Fig 6.10: front tyre force of the non-linear model, its ideal linearisation, and the
    linear tyres of the identified mean frictions."""
    p = VehicleParameters.from_settings(Settings.from_config(config))
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


def identification_figures(datasets: Mapping[str, xr.Dataset], config: Mapping[str, Any],
                           figure_paths: Sequence[str | Path], appendix_paths: Sequence[str | Path]) -> Iterator[tuple[Any, str | Path]]:
    """The figures of the identification experiments, one at a time, each with its output path.

    Parameters
    ----------
    datasets : mapping of str to xarray.Dataset
        Identification experiments by name; used here: ``basic``, ``inverted``,
        ``initial_guess``, ``noise`` and ``robust``.
    config : mapping
        The configuration (``vehicle`` for the tyre curves, ``noise.levels`` for the noise axis).
    figure_paths : sequence of str or Path
        PNG paths whose file stems name the figures (:data:`FIGURE_NAMES`: ``fig_6_7`` ...
        ``fig_6_15`` and ``fig_robust_start``), in any order; other paths are ignored.
    appendix_paths : sequence of str or Path
        PNG paths of Figs B.1-B.13 in the order of :data:`APPENDIX_B_PLAN`, named ``fig_B<k>``
        (the title is read from the stem: ``fig_B7`` is titled "Fig B.7").

    Yields
    ------
    figure : matplotlib.figure.Figure
        The figure, not yet saved; save (and close) it before asking for the next one.
    path : str or Path
        Where it goes, an element of ``figure_paths`` or ``appendix_paths``.

    Raises
    ------
    KeyError
        If a figure of the plan has no path in ``figure_paths`` (before any figure is drawn).
    ValueError
        If ``appendix_paths`` does not hold one path per entry of :data:`APPENDIX_B_PLAN`.
    """
    paths = {Path(p).stem: p for p in figure_paths}
    missing = [name for name in FIGURE_NAMES if name not in paths]
    if missing:
        raise KeyError(f"no output path for {missing}")
    if len(appendix_paths) != len(APPENDIX_B_PLAN):
        raise ValueError(f"{len(appendix_paths)} appendix paths given; Figs B.1-B.{len(APPENDIX_B_PLAN)} need {len(APPENDIX_B_PLAN)}")
    nlst, basic, noise, rob = list(NLST_ESTIMATES), datasets["basic"], datasets["noise"], datasets["robust"]
    excluded = basic.attrs.get("n_spun_excluded_nlst", 0)
    yield w2_per_run(basic, ["LST-STD"], "Fig 6.7: LST-LST, basic test"), paths["fig_6_7"]
    yield w2_per_run(basic, nlst, f"Fig 6.8: NLST-LST, basic test ({excluded} spun runs excluded)"), paths["fig_6_8"]
    yield distributions(datasets["inverted"], "NLST-STD", "Fig 6.9: NLST-LST [STD], inverted steering"), paths["fig_6_9"]
    mu_est = {e: float(np.nanmean(basic["theta"].sel(estimate=e, parameter="mu_mean"))) for e in nlst}
    yield tyre_curves_estimated(config, mu_est), paths["fig_6_10"]
    guess = datasets["initial_guess"]
    dev = 100 * guess["deviation"].values
    yield w2_against(guess, dev, "initial-guess deviation [%]", ["LST-STD"], "Fig 6.11: LST-LST, initial guesses"), paths["fig_6_11"]
    yield w2_against(guess, dev, "initial-guess deviation [%]", nlst, "Fig 6.12: NLST-LST, initial guesses"), paths["fig_6_12"]
    levels = [a for a in config["noise"]["levels"] if a > 0]
    yield (w2_against(noise, levels, "noise intensity A", ["LST-STD", "LST-STD noise-aware"], "Fig 6.13: LST-LST, noise (dashed: noise-aware, past the thesis)"),
           paths["fig_6_13"])
    yield w2_against(noise, levels, "noise intensity A", nlst + ["NLST-STD noise-aware"], "Fig 6.14: NLST-LST, noise (dashed: noise-aware)"), paths["fig_6_14"]
    yield distributions(noise, "LST-STD", "Fig 6.15: LST-LST [STD] for every noise level"), paths["fig_6_15"]
    yield (w2_against(rob, 100 * rob["deviation"].values, "initial-guess deviation [%]", list(rob["estimate"].values), "Robust start (past the thesis): single vs multi-start"),
           paths["fig_robust_start"])
    for path, (exp, est) in zip(appendix_paths, APPENDIX_B_PLAN):
        yield distributions(datasets[exp], est, f"{Path(path).stem[4:].replace('B', 'Fig B.')}: {est}, {exp.replace('_', '-')} test"), path

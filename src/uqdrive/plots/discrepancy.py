"""Figures of the discrepancy workflow: measured vs model bands before and after the named effect
is added, and the localisation map (signal x statistic x time, in units of the null band).
"""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np

from ..studies.discrepancy import detection_limits
from ..vehicle.channels import CHANNEL_NAMES
from ..vehicle.single_track import STATES
from .figure import BAND_SIGMAS, channel_grid, grid_legend

__all__ = ["bands_before_after", "localisation_map", "threshold_outlines", "confusion_matrix", "detection_vs_magnitude", "combined_confusion", "gap_per_effect",
           "channel_detection_table"]


def bands_before_after(time, measured, before, after, effect: str, band_sigmas: float = BAND_SIGMAS, channels=STATES):
    """Measured mean +- k std against the baseline and the augmented model, per measured channel.

    Parameters
    ----------
    time : ndarray, shape (K,)
    measured, before, after : ndarray, shape (2, C, K)
        [mean, std] of the data, the baseline model and the augmented model.
    effect : str
        The named effect (or ``none``), for the title and the legend.
    band_sigmas : float
        Half-width of the bands in standard deviations (the one convention of fit.png too).
    channels : sequence of str
        The C measured channels (default the four states).
    """
    k = f"{band_sigmas:g}"
    title = f"Measured vs model, mean +- {k} std: the baseline (LST) and with '{effect}'"
    fig, axes, spare = channel_grid(channels, title)
    for i, ax in enumerate(axes):
        m, s = measured[0, i], measured[1, i]
        ax.fill_between(time, m - band_sigmas * s, m + band_sigmas * s, color="0.8", label=f"measured mean +- {k} std")
        ax.plot(time, m, color="k", lw=1.0, label="measured mean")
        for stats, colour, name in ((before, "C3", "baseline"), (after, "C0", f"with {effect}")):
            ax.plot(time, stats[0, i], color=colour, lw=1.0, label=f"{name} mean")
            ax.plot(time, stats[0, i] + band_sigmas * stats[1, i], color=colour, lw=0.7, ls="--", label=f"{name} mean +- {k} std")
            ax.plot(time, stats[0, i] - band_sigmas * stats[1, i], color=colour, lw=0.7, ls="--")
    grid_legend(fig, axes, spare)
    return fig


def threshold_outlines(values, threshold: float):
    """The cells above ``threshold``, row by row: (row, first index, last index) of each run of
    consecutive cells of a row whose value exceeds it (a row's runs never join another row's).

    Parameters
    ----------
    values : ndarray, shape (R, K)
        A non-negative map, one row per signal and statistic.
    threshold : float
        The level (same units).

    Returns
    -------
    list of tuple of int
    """
    runs = []
    for r, row in enumerate(np.asarray(values) > threshold):
        edges = np.diff(np.concatenate([[0], row.astype(int), [0]]))
        runs += [(r, int(a), int(b) - 1) for a, b in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1))]
    return runs


def localisation_map(time, z, threshold: float, title: str = "Localisation of the gap", channels=STATES):
    """|z| of the baseline per signal and statistic over time, the cells above the scan
    threshold outlined row by row.

    The colour scale stops at three times the threshold (brighter cells are all "far beyond
    it"), so that a few very large cells, e.g. early in a run where the spread is small and the
    mean is pinned to a small fraction of itself, do not leave the rest of the map dark.

    Parameters
    ----------
    time : ndarray, shape (K,)
    z : ndarray, shape (2, C, K)
        Standardised gap (units of the null band) over the C measured ``channels``.
    threshold : float
        Family-wise threshold of the scan statistic (same units).
    channels : sequence of str
        The measured channels (default the four states).
    """
    from matplotlib.patches import Rectangle

    rows = [f"{s} {stat}" for stat in ("mean", "std") for s in channels]
    values = np.abs(np.asarray(z)).reshape(len(rows), -1)
    time = np.asarray(time, float)
    fig, ax = plt.subplots(figsize=(10, 1.2 + 0.42 * len(rows)), constrained_layout=True)
    top = 3.0 * threshold
    mesh = ax.pcolormesh(time, np.arange(len(rows)), values, shading="nearest", cmap="magma", vmin=0, vmax=top)
    step = float(np.median(np.diff(time))) if time.size > 1 else 1.0
    for r, a, b in threshold_outlines(values, threshold):
        ax.add_patch(Rectangle((time[a] - step / 2, r - 0.5), time[b] - time[a] + step, 1.0, fill=False, edgecolor="c", lw=0.9))
    ax.axhline(len(channels) - 0.5, color="w", lw=1.5)  # the means below, the stds above
    ax.set_yticks(np.arange(len(rows)), [f"{CHANNEL_NAMES[r.split()[0]]}: {r.split()[1]}" for r in rows], fontsize=8)
    ax.set_ylim(-0.5, len(rows) - 0.5)
    ax.set_xlabel("time [s]")
    cb = fig.colorbar(mesh, ax=ax, extend="max" if values.max() > top else "neither")
    cb.set_label("|z|: gap in units of the null band")
    ax.set_title(f"{title}: |measured - baseline| per signal and statistic\n"
                 f"cyan outlines: the cells above the family-wise threshold {threshold:.2f}", fontsize=10)
    return fig


def _counts(ax, m):
    """A count table m (rows, columns) as an image with each non-zero count written in its cell."""
    ax.imshow(m, cmap="Blues")
    for i in range(m.shape[0]):
        for j in range(m.shape[1]):
            if m[i, j]:
                ax.text(j, i, str(m[i, j]), ha="center", va="center", fontsize=9)


def confusion_matrix(ds):
    """Benchmark cases by true effect (rows) and named effect (columns)."""
    m = ds["confusion"].values
    fig, ax = plt.subplots(figsize=(1.0 + 0.7 * m.shape[1], 1.0 + 0.5 * m.shape[0]), constrained_layout=True)
    _counts(ax, m)
    ax.set_xticks(range(m.shape[1]), [str(v) for v in ds["named_effect"].values], rotation=45, ha="right", fontsize=8)
    ax.set_yticks(range(m.shape[0]), [str(v) for v in ds["true_effect"].values], fontsize=8)
    ax.set_xlabel("named by uqdrive discover")
    ax.set_ylabel("hidden in the data")
    ax.set_title(f"accuracy {ds.attrs['accuracy']:.2f}, false alarms {ds.attrs['false_alarm_rate']:.2f}")
    return fig


def detection_vs_magnitude(ds):
    """Per hidden effect (per channel for sensor effects): named correctly or missed against its
    magnitude, the smallest magnitude it is named at marked (dashed line, value in the title).

    Parameters
    ----------
    ds : xarray.Dataset
        :func:`uqdrive.studies.discrepancy.benchmark_dataset` (variables truth, channel, magnitude, correct).
    """
    limits = detection_limits(ds)
    cols = min(max(len(limits), 1), 4)
    rows = -(-max(len(limits), 1) // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(2.6 * cols, 2.2 * rows + 0.4), constrained_layout=True, squeeze=False)
    for ax in axes.flat[len(limits):]:
        ax.set_visible(False)
    for ax, (group, lim) in zip(axes.flat, limits.items()):
        mag, ok = np.array(lim["magnitudes"]), np.array(lim["named"], bool)
        ax.plot(mag[ok], np.ones(ok.sum()), "o", color="C0", label="named")
        ax.plot(mag[~ok], np.zeros((~ok).sum()), "x", color="C3", label="missed")
        smallest = lim["smallest_named"]
        if np.isfinite(smallest):
            ax.axvline(smallest, color="C0", ls="--", lw=0.8)
        span = max(float(np.ptp(mag)), 0.2 * max(float(np.max(np.abs(mag))), 1e-12))
        ax.set_xlim(float(mag.min()) - 0.5 * span, float(mag.max()) + 0.5 * span)
        ax.set_ylim(-0.3, 1.3)
        ax.set_yticks([0, 1], ["missed", "named"])
        found = f"found from {smallest:g}" if np.isfinite(smallest) else "never found"
        ax.set_title(f"{group}\n{found} {lim['unit']}" if np.isfinite(smallest) else f"{group}\n{found}", fontsize=7)
        ax.set_xlabel(f"magnitude [{lim['unit']}]", fontsize=7)
        ax.tick_params(labelsize=7)
        ax.grid(alpha=0.3)
    fig.suptitle("Detection versus magnitude: the smallest magnitude each effect is named at (dashed)", fontsize=8)
    return fig


def combined_confusion(ds):
    """Combined benchmark cases by hidden set of effects (rows) and named set (columns); a note
    when the benchmark ran none (e.g. a CI subset)."""
    if "confusion_combined" not in ds:
        fig, ax = plt.subplots(figsize=(4.0, 1.5), constrained_layout=True)
        ax.axis("off")
        ax.text(0.5, 0.5, "no combined cases in this benchmark run", ha="center", va="center")
        return fig
    m = ds["confusion_combined"].values
    fig, ax = plt.subplots(figsize=(2.0 + 0.9 * m.shape[1], 1.2 + 0.5 * m.shape[0]), constrained_layout=True)
    _counts(ax, m)
    ax.set_xticks(range(m.shape[1]), [str(v).replace("+", "+\n") for v in ds["named_set_column"].values], rotation=45, ha="right", fontsize=7)
    ax.set_yticks(range(m.shape[0]), [str(v) for v in ds["true_set"].values], fontsize=7)
    ax.set_xlabel("named set (order free)")
    ax.set_ylabel("hidden set")
    ax.set_title(f"combined cases: exact set and gap halved {ds.attrs['combined_accuracy']:.2f}", fontsize=9)
    return fig


def gap_per_effect(ds):
    """Gap (excess RMS in null-band units) before and after each added effect, one line per
    combined case (``gap_steps`` of :func:`uqdrive.studies.discrepancy.case_outcome`)."""
    fig, ax = plt.subplots(figsize=(6.0, 3.6), constrained_layout=True)
    combined = np.asarray(ds["combined"].values, bool) if "combined" in ds else np.zeros(ds.sizes["case"], bool)
    for k in np.flatnonzero(combined):
        gaps = [float(g) for g in str(ds["gap_steps"].values[k]).split(";") if g]
        ax.plot(range(len(gaps)), gaps, "o-", label=f"{ds['case'].values[k]}: {ds['named_set'].values[k]}")
    ax.set_yscale("symlog", linthresh=0.1)
    ax.set_xlabel("effects added")
    ax.set_ylabel("gap (excess RMS z)")
    ax.set_xticks(range(4))
    ax.grid(alpha=0.3)
    if combined.any():
        ax.legend(fontsize=6, loc="upper right")
    else:
        ax.text(0.5, 0.5, "no combined cases in this benchmark run", ha="center", va="center", transform=ax.transAxes)
    ax.set_title("Gap per added effect: each justified addition closes part of it", fontsize=9)
    return fig


def channel_detection_table(rows):
    """Detection by channel set and run count: one row per case, one column per (set, runs), each
    cell green where the verdict is right (the effect named, or ``none`` for a null case), red
    where not, with the verdict written in it.

    Parameters
    ----------
    rows : sequence of dict
        :func:`uqdrive.studies.discrepancy.channel_detection` (case, truth, magnitude, set, runs, verdict, correct).
    """
    cases = list(dict.fromkeys(r["case"] for r in rows))
    cols = list(dict.fromkeys((r["set"], r["runs"]) for r in rows))
    ok = np.full((len(cases), len(cols)), np.nan)
    fig, ax = plt.subplots(figsize=(max(4.5, 1.6 + 1.1 * len(cols)), 1.2 + 0.45 * len(cases)), constrained_layout=True)
    for r in rows:
        i, j = cases.index(r["case"]), cols.index((r["set"], r["runs"]))
        ok[i, j] = float(r["correct"])
        ax.text(j, i, r["verdict"].replace("_", " "), ha="center", va="center", fontsize=6)
    ax.imshow(ok, cmap="RdYlGn", vmin=-0.5, vmax=1.5, aspect="auto")
    labels = {"all": "all", "imu": "IMU", "imu_speed": "IMU + v(t)"}
    ax.set_xticks(np.arange(len(cols)), [f"{labels.get(s, s)}\n{n} runs" for s, n in cols], fontsize=7)
    truth = {r["case"]: r["truth"] if r["truth"] == "none" else f"{r['truth']} {r['magnitude']:g}" for r in rows}
    ax.set_yticks(np.arange(len(cases)), [truth[c] for c in cases], fontsize=7)
    ax.set_title("discover by channel set and run count\n(green: right, red: missed or false alarm)", fontsize=8)
    return fig

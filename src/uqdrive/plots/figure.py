"""The figure helpers every plot module shares: atomic PNG output and the 2 x 2 state layout.

Figures are made from datasets on disk (never from another rule's memory).
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from ..io import atomic_path  # noqa: E402
from ..vehicle.channels import CHANNEL_NAMES, CHANNEL_UNITS  # noqa: E402

__all__ = ["save_figure", "state_axes", "time_axis", "label_state", "channel_grid", "grid_legend", "BAND_SIGMAS"]

#: Half-width, in standard deviations, of every ensemble band uqdrive draws (fit.png, bands.png):
#: about 95 % of a normal channel's runs lie inside it.
BAND_SIGMAS = 2.0


def save_figure(fig, path: str | Path, dpi: int = 110) -> None:
    """Save ``fig`` as PNG atomically and close it.

    A figure with a layout engine (constrained layout: every figure of uqdrive's own) already fits
    its canvas and is saved as it is; one without (corner's) is cropped to what it draws. The crop
    costs a second layout pass (a fifth of the CPU of the 23 identification figures)."""
    bbox = None if fig.get_layout_engine() is not None else "tight"
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=dpi, bbox_inches=bbox, format="png")
    plt.close(fig)


def state_axes(nrows=2, ncols=2, title=""):
    """A figure with an ``nrows`` x ``ncols`` grid of axes sharing the time axis (one per state), and
    its flattened axes."""
    fig, axes = plt.subplots(nrows, ncols, figsize=(10, 6.5), sharex=True, constrained_layout=True)
    if title:
        fig.suptitle(title)
    return fig, np.atleast_1d(axes).ravel()


def time_axis(fig, axes):
    """Label the time axis of the bottom row of a 2 x 2 state figure; return the figure."""
    for ax in axes[-2:]:
        ax.set_xlabel("time [s]")
    return fig


def label_state(ax, state):
    """Label ``ax`` with the state's (or measured channel's) name and unit (``CHANNEL_UNITS``) and add a light grid."""
    ax.set_ylabel(f"{state} [{CHANNEL_UNITS[state]}]")
    ax.set_title(CHANNEL_NAMES[state])
    ax.grid(alpha=0.3)


def channel_grid(channels, title=""):
    """One panel per channel in two columns, each with its own time tick labels, the last row
    of each column labelled with time, a spare last panel (odd counts) kept for the legend.

    Returns the figure, the channels' axes (in ``channels`` order) and the spare axes or None.
    """
    channels = list(channels)
    ncols = 2 if len(channels) > 1 else 1
    nrows = -(-len(channels) // ncols)
    fig, axes = plt.subplots(nrows, ncols, figsize=(10, 2.3 * nrows + 1.2), sharex=True, constrained_layout=True, squeeze=False)
    if title:
        fig.suptitle(title)
    flat = axes.ravel()
    for ax in flat:
        ax.tick_params(labelbottom=True)  # a reader of an upper panel sees its times too
    for ax in flat[max(len(channels) - ncols, 0):len(channels)]:
        ax.set_xlabel("time [s]")
    spare = flat[len(channels)] if len(flat) > len(channels) else None
    for ax in flat[len(channels) + 1:]:
        ax.remove()
    if spare is not None:
        spare.axis("off")
    for ax, channel in zip(flat, channels):
        label_state(ax, channel)
    return fig, flat[: len(channels)], spare


def grid_legend(fig, axes, spare):
    """The legend of the first panel, in the spare panel where there is one, else below the
    panels, so that it covers no band."""
    handles, labels = axes[0].get_legend_handles_labels()
    if spare is not None:
        spare.legend(handles, labels, loc="center", fontsize=9, frameon=False)
    else:
        fig.legend(handles, labels, loc="outside lower center", ncols=min(len(labels), 4), fontsize=8, frameon=False)

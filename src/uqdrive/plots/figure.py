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

__all__ = ["save_figure", "state_axes", "time_axis", "label_state"]


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

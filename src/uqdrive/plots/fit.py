"""fit.png of ``uqdrive identify``: the measured mean +- 3 std of each channel against the
identified model's, with the fit's status in the title."""

from __future__ import annotations

from ..vehicle.channels import CHANNEL_UNITS
from ..vehicle.single_track import STATE_UNITS, STATES
from .figure import save_figure, state_axes

__all__ = ["fit_figure"]


def fit_figure(time, measured_mean, measured_std, model, path, title="Identified model vs measured ensemble: mean +- 3 std",
               channels=STATES):
    """fit.png: measured mean +- 3 std per channel (band) and the model's (lines).

    Parameters
    ----------
    time : ndarray, shape (T,)
        Output times (s).
    measured_mean, measured_std : ndarray, shape (C, T)
        Measured mean and std of each channel, in the channel's SI unit.
    model : tuple of two ndarrays (C, T), or None
        The identified model's mean and std.
    path : path of the PNG, or None
        None: the Figure is returned instead of saved.
    title : str
        Figure title.
    channels : sequence of str, length C
        The channels' names, in the order of the rows.
    """
    channels = list(channels)
    fig, axes = state_axes(nrows=(len(channels) + 1) // 2 if len(channels) > 1 else 1, ncols=2 if len(channels) > 1 else 1,
                           title=title)
    for ax in axes[len(channels):]:
        ax.axis("off")  # a spare panel holds the legend
    for i, (ax, state) in enumerate(zip(axes, channels)):
        m, s = measured_mean[i], measured_std[i]
        ax.fill_between(time, m - 3 * s, m + 3 * s, color="C0", alpha=0.25, label="measured mean +- 3 std")
        ax.plot(time, m, color="C0", label="measured mean")
        if model is not None:
            ax.plot(time, model[0][i], "C3--", label="identified mean")
            ax.plot(time, model[0][i] + 3 * model[1][i], "C3:", lw=0.8, label="identified +- 3 std")
            ax.plot(time, model[0][i] - 3 * model[1][i], "C3:", lw=0.8)
        ax.set_title(f"{state} [{STATE_UNITS[state] if state in STATES else CHANNEL_UNITS[state]}]")
        ax.grid(alpha=0.3)
    for ax in axes[max(len(channels) - 2, 0):len(channels)]:
        ax.set_xlabel("time [s]")
        ax.tick_params(labelbottom=True)  # the last row of each column, also above a hidden panel
    spare = axes[len(channels):]
    (spare[0].legend(*axes[0].get_legend_handles_labels(), loc="center") if len(spare) else axes[0].legend(fontsize=8))
    if path is None:
        return fig
    save_figure(fig, path)
    return None

"""fit.png of ``uqdrive identify``: the measured mean +- 2 std of each channel against the
identified model's, with the fit's status in the title."""

from __future__ import annotations

from ..vehicle.single_track import STATES
from .figure import BAND_SIGMAS, channel_grid, grid_legend, save_figure

__all__ = ["fit_figure"]


def fit_figure(time, measured_mean, measured_std, model, path, title="Identified model vs measured ensemble", channels=STATES,
               status=None):
    """fit.png: measured mean +- 2 std per channel (band) and the model's (lines), the bands of
    bands.png (:data:`~uqdrive.plots.figure.BAND_SIGMAS`).

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
        What the figure compares; the band's width and the status follow it.
    channels : sequence of str, length C
        The channels' names, in the order of the rows.
    status : str, optional
        The fit's status in words (:func:`uqdrive.cli.identify.fit_status`), on the title's second line.
    """
    k = f"{BAND_SIGMAS:g}"
    heading = f"{title}, mean +- {k} std" + (f"\nfit: {status}" if status else "")
    fig, axes, spare = channel_grid(channels, heading)
    for i, ax in enumerate(axes):
        m, s = measured_mean[i], measured_std[i]
        ax.fill_between(time, m - BAND_SIGMAS * s, m + BAND_SIGMAS * s, color="0.8", label=f"measured mean +- {k} std")
        ax.plot(time, m, color="k", lw=1.0, label="measured mean")
        if model is not None:
            ax.plot(time, model[0][i], color="C3", lw=1.0, label="identified model mean")
            ax.plot(time, model[0][i] + BAND_SIGMAS * model[1][i], color="C3", lw=0.7, ls="--", label=f"identified model mean +- {k} std")
            ax.plot(time, model[0][i] - BAND_SIGMAS * model[1][i], color="C3", lw=0.7, ls="--")
    grid_legend(fig, axes, spare)
    if path is None:
        return fig
    save_figure(fig, path)
    return None

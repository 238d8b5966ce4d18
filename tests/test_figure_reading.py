"""The ensemble figures read as a reader needs: every panel has its time tick labels and a title
in words, the bands of fit.png and bands.png are the same mean +- 2 std and named in the legend,
the legend covers no panel, fit.png states the fit's status, and localisation.png outlines the
cells above the threshold row by row."""

import numpy as np
import pytest

from uqdrive.plots.discrepancy import bands_before_after, localisation_map, threshold_outlines
from uqdrive.plots.figure import BAND_SIGMAS
from uqdrive.plots.fit import fit_figure
from uqdrive.vehicle.channels import CHANNEL_NAMES, CHANNELS

T = np.linspace(0.0, 10.0, 101)


def _stats(offset=0.0):
    wave = np.stack([np.sin(T + k) for k in range(len(CHANNELS))]) + offset
    return np.stack([wave, 0.1 + 0.0 * wave])  # (2, C, K)


def _panels(fig):
    return [ax for ax in fig.axes if ax.lines or ax.collections]


def _overlaps(fig, box, axes):
    fig.canvas.draw()
    r = fig.canvas.get_renderer()
    lb = box.get_window_extent(r)
    return [ax for ax in axes if lb.overlaps(ax.get_window_extent(r))]


@pytest.mark.parametrize("channels", [CHANNELS, CHANNELS[:4]])
def test_bands_figure_has_ticks_words_a_named_band_and_a_legend_beside_the_panels(channels):
    c = len(channels)
    s = _stats()[:, :c]
    fig = bands_before_after(T, s, _stats(0.1)[:, :c], _stats(0.01)[:, :c], "tyre_saturation", channels=channels)
    panels = _panels(fig)
    assert len(panels) == c
    for ax, ch in zip(panels, channels):
        assert ax.get_title() == CHANNEL_NAMES[ch]
        assert all(t.get_visible() for t in ax.get_xticklabels()) and ax.xaxis.get_tick_params()["labelbottom"]
    labels = [t.get_text() for leg in fig.legends + [a.get_legend() for a in fig.axes if a.get_legend()] for t in leg.get_texts()]
    assert f"baseline mean +- {BAND_SIGMAS:g} std" in labels and f"measured mean +- {BAND_SIGMAS:g} std" in labels
    legend = (fig.legends or [a.get_legend() for a in fig.axes if a.get_legend()])[0]
    assert not _overlaps(fig, legend, panels)  # the yaw-angle band (and every other) stays visible
    # the measured band is +-2 std wide: the fill spans mean -+ BAND_SIGMAS * std
    fill = panels[0].collections[0].get_paths()[0].vertices[:, 1]
    assert fill.max() == pytest.approx((s[0, 0] + BAND_SIGMAS * s[1, 0]).max())


def test_fit_figure_states_the_status_with_the_same_band_and_the_a_y_panel():
    s = _stats()
    fig = fit_figure(T, s[0], s[1], (s[0] + 0.01, s[1]), None, channels=CHANNELS, status="optimiser converged, model does not fit")
    assert "model does not fit" in fig.get_suptitle() and f"mean +- {BAND_SIGMAS:g} std" in fig.get_suptitle()
    panels = _panels(fig)
    assert [ax.get_title() for ax in panels] == [CHANNEL_NAMES[c] for c in CHANNELS]
    assert panels[-1].get_ylabel() == "a_y [m/s^2]" and panels[-1].get_xlabel() == "time [s]"
    assert all(ax.xaxis.get_tick_params()["labelbottom"] for ax in panels)
    fill = panels[0].collections[0].get_paths()[0].vertices[:, 1]
    assert fill.max() == pytest.approx((s[0, 0] + BAND_SIGMAS * s[1, 0]).max())


def test_threshold_outlines_stay_in_their_row():
    values = np.array([[0, 5, 5, 0, 5], [5, 5, 0, 0, 0], [0, 0, 0, 0, 0]], float)
    assert threshold_outlines(values, 1.0) == [(0, 1, 2), (0, 4, 4), (1, 0, 1)]
    z = np.zeros((2, 2, T.size))
    z[0, 0, 10:20] = 9.0  # psi mean above the threshold; the row above it is not
    fig = localisation_map(T, z, 4.0, channels=("psi", "psi_dot"))
    boxes = [p.get_bbox() for p in fig.axes[0].patches]
    assert len(boxes) == 1 and boxes[0].y0 == pytest.approx(-0.5) and boxes[0].y1 == pytest.approx(0.5)
    assert boxes[0].x0 == pytest.approx(T[10] - 0.05) and boxes[0].x1 == pytest.approx(T[19] + 0.05)

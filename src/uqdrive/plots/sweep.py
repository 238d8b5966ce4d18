"""The figure of a sweep: every collected metric against every swept value.

One row of panels per metric quantity (a group's quantity, e.g. the W2 of mu in the noise
test), one column per swept key; in each panel a line per series (an estimate, a model...).
"""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import xarray as xr  # noqa: E402

__all__ = ["sweep_figure"]


def _panels(ds: xr.Dataset) -> list[tuple[str, str, list[int]]]:
    """(group, quantity, metric indices) in the order the metrics first appear."""
    panels: dict[tuple[str, str], list[int]] = {}
    for i, (g, q) in enumerate(zip(ds["metric_group"].values, ds["metric_quantity"].values)):
        panels.setdefault((str(g), str(q)), []).append(i)
    return [(g, q, idx) for (g, q), idx in panels.items()]


def sweep_figure(ds: xr.Dataset):
    """Figure of a sweep summary (:func:`uqdrive.studies.sweep.summary.summary_dataset`)."""
    panels, keys = _panels(ds), [str(k) for k in ds["key"].values]
    n_rows, n_cols = max(len(panels), 1), len(keys)
    fig, axes = plt.subplots(n_rows, n_cols, figsize=(4.2 * n_cols + 1.5, 2.3 * n_rows + 0.8), squeeze=False, constrained_layout=True)
    fig.suptitle(f"Sweep {ds.attrs.get('sweep', '')}: each metric against each swept value")
    points = np.arange(ds.sizes["point"])
    for col, key in enumerate(keys):
        x = ds["swept_axis"].sel(key=key).values
        numeric = np.all(np.isfinite(x))
        xs = x if numeric else points
        order = np.argsort(xs, kind="stable")
        for row, (group, quantity, idx) in enumerate(panels):
            ax = axes[row, col]
            for i in idx:
                y = ds["value"].values[:, i]
                label = str(ds["metric_series"].values[i]) or quantity
                ax.plot(xs[order], y[order], "o-", ms=4, lw=1.2, label=label)
            ax.set_title(f"{group}: {quantity}", fontsize=9)
            ax.grid(alpha=0.3)
            if len(idx) > 1 or str(ds["metric_series"].values[idx[0]]):
                ax.legend(fontsize=7)
            if row == n_rows - 1:
                ax.set_xlabel(f"{key}{ds['axis_index'].sel(key=key).item()}")
            if not numeric:
                ax.set_xticks(points, [str(v) for v in ds["swept_value"].sel(key=key).values], rotation=30, fontsize=7)
    return fig

"""Rule fig_appendix_a: thesis Figs A.1-A.22, one per model and noise intensity."""
import sys

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821

import xarray as xr

from uqdrive.plots import data as plots

p = snakemake.params  # noqa: F821
stats = {model: xr.load_dataset(snakemake.input[model]) for model in ("lst", "nlst")}  # noqa: F821
for (model, index), path in zip(p.figures, snakemake.output):  # noqa: F821
    A = float(stats[model]["noise"].values[index])
    title = f"Data from the {model.upper()} model with A = {A:g}"
    plots.save_figure(plots.ensemble_band(stats[model], p.band_sigmas, title, noise_index=index), path)

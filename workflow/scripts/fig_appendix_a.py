"""Rule fig_appendix_a: thesis Figs A.1-A.22, one per model and noise intensity."""
import sys

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821

import xarray as xr

from uqdrive.plots import data as plots

p = snakemake.params  # noqa: F821
stats = xr.load_dataset(snakemake.input.stats)  # noqa: F821
A = float(stats["noise"].values[p.index])
title = f"Data from the {p.model.upper()} model with A = {A:g}"
plots.save_figure(plots.ensemble_band(stats, p.band_sigmas, title, noise_index=p.index), snakemake.output[0])  # noqa: F821

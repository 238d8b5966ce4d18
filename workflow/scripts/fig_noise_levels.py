"""Rule fig_noise_levels: thesis Figs 6.3 (LST) and 6.4 (NLST)."""
import sys

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821

import xarray as xr

from uqdrive.plots import data as plots

stats = xr.load_dataset(snakemake.input.stats)  # noqa: F821
title = f"{stats.attrs['model'].upper()} data for each noise intensity A"
plots.save_figure(plots.noise_levels(stats, title), snakemake.output[0])  # noqa: F821

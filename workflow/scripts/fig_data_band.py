"""Rule fig_data_band: thesis Figs 6.1 (LST) and 6.2 (NLST)."""
import sys

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821

import xarray as xr

from uqdrive.plots import data as plots

stats = xr.load_dataset(snakemake.input.stats)  # noqa: F821
title = f"{stats.attrs['model'].upper()} data, {stats.attrs['n_used']} of {stats.attrs['n_samples']} samples ({stats.attrs['spin_policy']} spun)"
plots.save_figure(plots.ensemble_band(stats, snakemake.params.band_sigmas, title), snakemake.output[0])  # noqa: F821

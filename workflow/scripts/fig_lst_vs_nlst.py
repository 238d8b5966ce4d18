"""Rule fig_lst_vs_nlst: thesis Figs 6.5 and 6.6."""
import sys

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821

import xarray as xr

from uqdrive.plots import data as plots

i = snakemake.input  # noqa: F821
lst, nlst, kl = xr.load_dataset(i.lst), xr.load_dataset(i.nlst), xr.load_dataset(i.kl)
plots.save_figure(plots.lst_vs_nlst(lst, nlst, snakemake.params.band_sigmas), snakemake.output.comparison)  # noqa: F821
plots.save_figure(plots.kl_divergence(kl), snakemake.output.kl)  # noqa: F821

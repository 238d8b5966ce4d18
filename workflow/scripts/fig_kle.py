"""Rule fig_kle: thesis Figs 5.2 and 7.1."""
import sys

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821

import xarray as xr

from uqdrive.plots import data as plots

kle = xr.load_dataset(snakemake.input.kle)  # noqa: F821
plots.save_figure(plots.kle_realisations(kle), snakemake.output.realisations)  # noqa: F821
plots.save_figure(plots.kle_eigenfunctions(kle), snakemake.output.eigenfunctions)  # noqa: F821

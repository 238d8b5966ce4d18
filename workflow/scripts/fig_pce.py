"""Rule fig_pce: thesis Figs 5.3, 5.4 and the PCE convergence figure."""
import sys

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821

import xarray as xr

from uqdrive.plots import pce as plots
from uqdrive.plots.figure import save_figure

i, o = snakemake.input, snakemake.output  # noqa: F821
pce, mc, conv = xr.load_dataset(i.pce), xr.load_dataset(i.mc), xr.load_dataset(i.convergence)
save_figure(plots.pce_vs_monte_carlo(pce, mc, snakemake.params.band_sigmas), o.comparison)  # noqa: F821
save_figure(plots.sobol_indices(pce), o.sobol)
save_figure(plots.pce_convergence(conv), o.convergence)

"""Rule fig_tyre_curves: thesis Fig 2.3."""
import sys

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821

from uqdrive.plots import data as plots

plots.save_figure(plots.tyre_curves(snakemake.params.surfaces), snakemake.output[0])  # noqa: F821

"""Rule fig_control: Figs 6.16-6.18, gamma sweep, gain table and control scorecard rows."""
import sys

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821

import xarray as xr

from uqdrive.io import write_csv_rows
from uqdrive.plots import control as pc
from uqdrive.plots.figure import save_figure
from uqdrive.studies.control import controller_table_rows
from uqdrive.studies.scorecard import control_rows, write_scorecard

i, o, band = snakemake.input, snakemake.output, snakemake.params.band_sigmas  # noqa: F821
gains, lst, nlst, sweep = (xr.load_dataset(p) for p in (i.gains, i.lst, i.nlst, i.sweep))
save_figure(pc.closed_loop_bands("Fig 6.16: LST with the LQR", gains, lst, ["LQR"], band), o.fig_6_16)
save_figure(pc.closed_loop_bands("Fig 6.17: LST with the LQR and the SLQR", gains, lst, ["LQR", "SLQR"], band), o.fig_6_17)
save_figure(pc.closed_loop_bands("Fig 6.18: NLST with the LQR, the SLQR and the SLQR on identified distributions", None, nlst, list(nlst["controller"].values), band), o.fig_6_18)
save_figure(pc.gamma_sweep_figure(sweep), o.sweep)
write_csv_rows(controller_table_rows(gains, lst, nlst), o.table)
write_scorecard(control_rows(gains), o.scorecard)

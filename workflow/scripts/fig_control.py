"""Rule fig_control: Figs 6.16-6.18, gamma sweep, gain table and control scorecard rows."""
import csv
import sys

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821

import numpy as np
import xarray as xr

from uqdrive import plots_control as pc
from uqdrive.io import atomic_path
from uqdrive.plots import save_figure
from uqdrive.scorecard import control_rows, write_scorecard

i, o, band = snakemake.input, snakemake.output, snakemake.params.band_sigmas  # noqa: F821
gains, lst, nlst, sweep = (xr.load_dataset(p) for p in (i.gains, i.lst, i.nlst, i.sweep))
save_figure(pc.closed_loop_bands("Fig 6.16: LST with the LQR", gains, lst, ["LQR"], band), o.fig_6_16)
save_figure(pc.closed_loop_bands("Fig 6.17: LST with the LQR and the SLQR", gains, lst, ["LQR", "SLQR"], band), o.fig_6_17)
save_figure(pc.closed_loop_bands("Fig 6.18: NLST with the LQR, the SLQR and the SLQR on identified distributions", None, nlst, list(nlst["controller"].values), band), o.fig_6_18)
save_figure(pc.gamma_sweep_figure(sweep), o.sweep)
rows = []
for name in gains["controller"].values:
    row = {"controller": str(name), "K": np.array2string(gains["K"].sel(controller=name).values, precision=3)}
    for model, mc in (("LST", lst), ("NLST", nlst)):
        for var in ("y", "beta", "delta"):
            x = mc[var].sel(controller=name).values
            row[f"{model} mean |{var}| (t>1s)"] = f"{np.abs(x.mean(axis=0)[mc['time'].values > 1]).mean():.3g}"
            row[f"{model} var {var} (t>1s)"] = f"{x.var(axis=0, ddof=1)[mc['time'].values > 1].mean():.3g}"
        row[f"{model} unstable runs"] = int((1 - mc["stable"].sel(controller=name).values).sum())
    rows.append(row)
with atomic_path(o.table) as tmp:
    with open(tmp, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
write_scorecard(control_rows(gains), o.scorecard)

"""Rule fig_identification: Figs 6.7-6.15, B.1-B.13, Tables 6.2/6.3, identifiability table."""
import csv
import shutil
import sys

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821

import numpy as np
import xarray as xr

from uqdrive import plots_identification as pi
from uqdrive.identification_tables import THESIS_TABLE_6_2, THESIS_TABLE_6_3, table_rows, table_scorecard_rows
from uqdrive.io import atomic_path
from uqdrive.plots import save_figure
from uqdrive.scorecard import write_scorecard

i, o, config = snakemake.input, snakemake.output, snakemake.params.config  # noqa: F821
ds = {e: xr.load_dataset(i[e]) for e in snakemake.params.experiments}  # noqa: F821
figs = dict(zip([p.split("/")[-1][:-4] for p in o.figures], o.figures))
nlst = ["NLST-STD", "NLST-INP", "NLST-DST"]
four = ["LST-STD"] + nlst
excluded = ds["basic"].attrs.get("n_spun_excluded_nlst", 0)
save_figure(pi.w2_per_run(ds["basic"], ["LST-STD"], "Fig 6.7: LST-LST, basic test"), figs["fig_6_7"])
save_figure(pi.w2_per_run(ds["basic"], nlst, f"Fig 6.8: NLST-LST, basic test ({excluded} spun runs excluded)"), figs["fig_6_8"])
save_figure(pi.distributions(ds["inverted"], "NLST-STD", "Fig 6.9: NLST-LST [STD], inverted steering"), figs["fig_6_9"])
mu_est = {e: float(np.nanmean(ds["basic"]["theta"].sel(estimate=e, parameter="mu_mean"))) for e in nlst}
save_figure(pi.tyre_curves_estimated(config, mu_est), figs["fig_6_10"])
dev = 100 * ds["initial_guess"]["deviation"].values
save_figure(pi.w2_against(ds["initial_guess"], dev, "initial-guess deviation [%]", ["LST-STD"], "Fig 6.11: LST-LST, initial guesses"), figs["fig_6_11"])
save_figure(pi.w2_against(ds["initial_guess"], dev, "initial-guess deviation [%]", nlst, "Fig 6.12: NLST-LST, initial guesses"), figs["fig_6_12"])
levels = [a for a in config["noise"]["levels"] if a > 0]
save_figure(pi.w2_against(ds["noise"], levels, "noise intensity A", ["LST-STD", "LST-STD noise-aware"], "Fig 6.13: LST-LST, noise (dashed: noise-aware, past the thesis)"), figs["fig_6_13"])
save_figure(pi.w2_against(ds["noise"], levels, "noise intensity A", nlst + ["NLST-STD noise-aware"], "Fig 6.14: NLST-LST, noise (dashed: noise-aware)"), figs["fig_6_14"])
save_figure(pi.distributions(ds["noise"], "LST-STD", "Fig 6.15: LST-LST [STD] for every noise level"), figs["fig_6_15"])
rob = ds["robust"]
save_figure(pi.w2_against(rob, 100 * rob["deviation"].values, "initial-guess deviation [%]", list(rob["estimate"].values), "Robust start (past the thesis): single vs multi-start"), figs["fig_robust_start"])
b_plan = [("basic", e) for e in four] + [("initial_guess", e) for e in four] + [("noise", e) for e in nlst] + [("inverted", e) for e in nlst[1:]]
for path, (exp, est) in zip(o.appendix, b_plan):
    save_figure(pi.distributions(ds[exp], est, f"{path.split('/')[-1][4:-4].replace('B', 'Fig B.')}: {est}, {exp.replace('_', '-')} test"), path)
for path, d, ref in ((o.table_6_2, ds["basic"], THESIS_TABLE_6_2), (o.table_6_3, ds["inverted"], THESIS_TABLE_6_3)):
    rows = table_rows(d, ref)
    if path == o.table_6_2 and "no_wind_moment" in ds:
        rows += [dict(r, estimate=r["estimate"] + " (M_c = 0)") for r in table_rows(ds["no_wind_moment"], ref)]
    variant = "normalised" if path == o.table_6_2 else "normalised_inverted"
    if variant in ds:
        rows += [dict(r, estimate=r["estimate"] + " (unit-free residuals)") for r in table_rows(ds[variant], ref)]
    with atomic_path(path) as tmp:
        with open(tmp, "w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)
shutil.copyfile(i.identifiability, o.identifiability)
write_scorecard(table_scorecard_rows(ds["basic"], ds["inverted"], ds.get("no_wind_moment"), ds.get("normalised"), ds.get("normalised_inverted")), o.scorecard)

"""Rule fig_bayes: corner and trace plots, summary table, scorecard rows of the cross-check."""
import csv
import sys

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821

import numpy as np
import xarray as xr

from uqdrive import plots_bayes as pb
from uqdrive.bayes_study import summarise
from uqdrive.io import atomic_path
from uqdrive.plots import save_figure
from uqdrive.scorecard import bayes_rows, write_scorecard

i, o = snakemake.input, snakemake.output  # noqa: F821
titles = {"lst": "LST-LST", "nlst": "NLST-LST", "lst_noise": "LST-LST, A = 0.05 (noise-aware)"}
posts = {c: xr.load_dataset(p) for c, p in zip(snakemake.params.cases, i.posteriors)}  # noqa: F821
rows, summaries = [], {}
for (case, ds), corner_path, trace_path in zip(posts.items(), o.corners, o.traces):
    save_figure(pb.corner_plot(ds, titles[case]), corner_path)
    save_figure(pb.trace_plot(ds, titles[case]), trace_path)
    s = summaries[case] = summarise(ds)
    n_steps = np.array([np.isfinite(ds["chain"].values[e, :, 0, 0]).sum() for e in range(ds.sizes["ensemble"])])
    for j, name in enumerate(ds["parameter"].values):
        rows.append({"case": titles[case], "parameter": str(name), "posterior mean": f"{s['mean'][j]:.4g}",
                     "95% interval": f"[{s['low'][j]:.4g}, {s['high'][j]:.4g}]", "optimiser": f"{ds.attrs['optimiser_estimate'][j]:.4g}",
                     "optimiser (unit-free)": f"{ds.attrs['optimiser_estimate_unit_free'][j]:.4g}" if "optimiser_estimate_unit_free" in ds.attrs else "",
                     "truth": f"{ds.attrs['truth'][j]:.4g}", "tau": f"{np.nanmax(ds['tau'].values[:, j]):.0f}",
                     "N/tau": f"{np.nanmin(n_steps / ds['tau'].values[:, j]):.0f}", "R-hat": f"{ds['r_hat'].values[j]:.3f}",
                     "ESS": f"{ds['ess'].values[j]:.0f}", "seconds": f"{ds.attrs['seconds']:.0f}"})
with atomic_path(o.table) as tmp:
    with open(tmp, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
cov = xr.load_dataset(i.coverage)
write_scorecard(bayes_rows(summaries, cov.attrs["hits"], cov.attrs["total"]), o.scorecard)

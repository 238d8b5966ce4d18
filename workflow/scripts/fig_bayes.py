"""Rule fig_bayes: corner and trace plots, summary table, scorecard rows of the cross-check."""
import sys

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821

import xarray as xr

from uqdrive.io import write_csv_rows
from uqdrive.plots import bayes as pb
from uqdrive.plots.figure import save_figure
from uqdrive.studies.bayes import posterior_table_rows, summarise
from uqdrive.studies.scorecard import bayes_rows, write_scorecard

i, o = snakemake.input, snakemake.output  # noqa: F821
titles = {"lst": "LST-LST", "nlst": "NLST-LST", "lst_noise": "LST-LST, A = 0.05 (noise-aware)"}
posts = {c: xr.load_dataset(p) for c, p in zip(snakemake.params.cases, i.posteriors)}  # noqa: F821
for (case, ds), corner_path, trace_path in zip(posts.items(), o.corners, o.traces):
    save_figure(pb.corner_plot(ds, titles[case]), corner_path)
    save_figure(pb.trace_plot(ds, titles[case]), trace_path)
summaries = {case: summarise(ds) for case, ds in posts.items()}
write_csv_rows(posterior_table_rows(posts, titles, summaries), o.table)
cov = xr.load_dataset(i.coverage)
write_scorecard(bayes_rows(summaries, cov.attrs["hits"], cov.attrs["total"]), o.scorecard)

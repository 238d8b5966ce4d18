"""Rule sweep_summary: one row a point (swept values, metrics, provenance) and the figure of each
metric against each swept value."""
import sys

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821

import json

from uqdrive.io import write_csv_rows, write_dataset
from uqdrive.plots.figure import save_figure
from uqdrive.plots.sweep import sweep_figure
from uqdrive.studies.sweep.summary import summary_dataset, summary_rows

i, o, p = snakemake.input, snakemake.output, snakemake.params  # noqa: F821
ds = summary_dataset(p.sweep, [json.loads(open(f).read()) for f in i.points])
ds.attrs["sweep_file"] = p.file
write_dataset(ds, o.nc)
write_csv_rows(summary_rows(ds), o.csv)
save_figure(sweep_figure(ds), o.figure)

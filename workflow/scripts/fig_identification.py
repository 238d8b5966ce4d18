"""Rule fig_identification: Figs 6.7-6.15, B.1-B.13, Tables 6.2/6.3, identifiability table."""
import shutil
import sys

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821

import xarray as xr

from uqdrive.io import write_csv_rows
from uqdrive.plots.figure import save_figure
from uqdrive.plots.identification import identification_figures
from uqdrive.studies.scorecard import write_scorecard
from uqdrive.studies.tables import table_scorecard_rows, thesis_table_rows

i, o, config = snakemake.input, snakemake.output, snakemake.params.config  # noqa: F821
ds = {e: xr.load_dataset(i[e]) for e in snakemake.params.experiments}  # noqa: F821
for fig, path in identification_figures(ds, config, o.figures, o.appendix):
    save_figure(fig, path)
write_csv_rows(thesis_table_rows(ds, "6.2"), o.table_6_2)
write_csv_rows(thesis_table_rows(ds, "6.3"), o.table_6_3)
shutil.copyfile(i.identifiability, o.identifiability)
write_scorecard(table_scorecard_rows(ds["basic"], ds["inverted"], ds.get("no_wind_moment"), ds.get("normalised"), ds.get("normalised_inverted")), o.scorecard)

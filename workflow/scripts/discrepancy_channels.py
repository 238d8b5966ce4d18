"""Rule discrepancy_channels: the detection table by channel set and run count from its cells (table and figure)."""
import json
import sys
from pathlib import Path

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821

from uqdrive.io import write_csv_rows
from uqdrive.plots.discrepancy import channel_detection_table
from uqdrive.plots.figure import save_figure

o = snakemake.output  # noqa: F821
rows = [row for path in snakemake.input.cells for row in json.loads(Path(path).read_text())]  # noqa: F821
write_csv_rows(rows, o.table)
save_figure(channel_detection_table(rows), o.figure)

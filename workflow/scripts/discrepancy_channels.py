"""Rule discrepancy_channels: discover by channel set and run count (table and figure)."""
import sys

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821

from uqdrive.io import write_csv_rows
from uqdrive.plots.discrepancy import channel_detection_table
from uqdrive.plots.figure import save_figure
from uqdrive.studies.discrepancy import channel_detection
from uqdrive.studies.hidden_effects import benchmark_cases

config, o = snakemake.config, snakemake.output  # noqa: F821
settings = config["discrepancy"]["channel_sets"]
cases = {c.name: c for c in benchmark_cases(config)}
rows = channel_detection(config, [cases[name] for name in settings["cases"]], settings["sets"], settings["runs"])
write_csv_rows(rows, o.table)
save_figure(channel_detection_table(rows), o.figure)

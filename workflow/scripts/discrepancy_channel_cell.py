"""Rule discrepancy_channel_cell: discover on one case of the table by one channel set at one run count (its row as JSON)."""
import json
import sys

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821

from uqdrive.io import atomic_path
from uqdrive.studies.discrepancy import channel_detection_cell
from uqdrive.studies.hidden_effects import benchmark_cases

config, w = snakemake.params.config, snakemake.wildcards  # noqa: F821
case = {c.name: c for c in benchmark_cases(config)}[w.table_case]
rows = channel_detection_cell(config, [case], w.channel_set, int(w.runs))
with atomic_path(snakemake.output[0]) as tmp:  # noqa: F821
    tmp.write_text(json.dumps(rows, indent=1) + "\n")

"""Rule scorecard_provenance: the merged scorecard with what its numbers trace to in every row:
the config (path and any --config overrides), its hash, the seed and the uqdrive version."""
import csv
import sys

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821

from uqdrive.io import write_csv_rows

with open(snakemake.input.merged, newline="") as fh:  # noqa: F821
    rows = [dict(row, **snakemake.params.provenance) for row in csv.DictReader(fh)]  # noqa: F821
write_csv_rows(rows, snakemake.output[0])  # noqa: F821

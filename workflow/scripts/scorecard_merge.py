"""Rule scorecard: merge every experiment family's rows into results/scorecard.csv."""
import sys

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821

from uqdrive.studies.scorecard import read_scorecard, write_scorecard

rows = [row for part in snakemake.input.parts for row in read_scorecard(part)]  # noqa: F821
write_scorecard(rows, snakemake.output[0])  # noqa: F821

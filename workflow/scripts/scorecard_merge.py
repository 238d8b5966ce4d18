"""Rule scorecard: merge every experiment family's rows into results/scorecard.csv and log the
counts per status with every row that is not in order (a `fail`, a `deviates` without reason)."""
import sys

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821

from uqdrive.studies.scorecard import check_scorecard, read_scorecard, write_scorecard

rows = [row for part in snakemake.input.parts for row in read_scorecard(part)]  # noqa: F821
write_scorecard(rows, snakemake.output[0])  # noqa: F821
# The scorecard is written whatever its state (the report shows it); tests/test_scorecard_rows.py
# fails on a default run's scorecard with a problem.
summary = check_scorecard(rows, strict=False)
print(f"scorecard: {summary['total']} rows, {summary['pass']} pass, {summary['deviates']} deviates, {summary['fail']} fail", file=sys.stderr)
for line in summary["problems"]:
    print(f"  {line}", file=sys.stderr)

"""Rule discrepancy_summary: benchmark outcomes, confusion matrix, detection figure, scorecard."""
import json
import sys

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821

from uqdrive.io import write_csv_rows, write_dataset
from uqdrive.plots import discrepancy as pd
from uqdrive.plots.figure import save_figure
from uqdrive.studies.discrepancy import benchmark_dataset, benchmark_rows, case_outcome
from uqdrive.studies.scorecard import write_scorecard

i, o = snakemake.input, snakemake.output  # noqa: F821
outcomes = [case_outcome(json.loads(open(lab).read()), json.loads(open(f"{ver}/verdict.json").read())) for lab, ver in zip(i.labels, i.verdicts)]
ds = benchmark_dataset(outcomes)
write_dataset(ds, o.dataset)
write_csv_rows(outcomes, o.table)
save_figure(pd.confusion_matrix(ds), o.confusion)
save_figure(pd.detection_vs_magnitude(ds), o.detection)
save_figure(pd.combined_confusion(ds), o.combined)
save_figure(pd.gap_per_effect(ds), o.gaps)
write_scorecard(benchmark_rows(ds), o.scorecard)

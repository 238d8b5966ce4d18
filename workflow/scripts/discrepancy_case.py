"""Rule discrepancy_case: one hidden-effect ensemble (measured.nc) and, apart, its label."""
import json
import sys

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821

from uqdrive.io import atomic_path, write_dataset
from uqdrive.studies.hidden_effects import benchmark_cases, case_label, generate

config = snakemake.params.config  # noqa: F821
case = {c.name: c for c in benchmark_cases(config, samples=config["discrepancy"]["benchmark"]["samples"])}[snakemake.wildcards.case]  # noqa: F821
write_dataset(generate(config, case), snakemake.output.measured)  # noqa: F821
with atomic_path(snakemake.output.label) as tmp:  # noqa: F821
    tmp.write_text(json.dumps(case_label(case), indent=2) + "\n")

"""Rule discrepancy_discover: one hidden-effect ensemble (measured.nc, its label apart) and
`uqdrive discover` on that file (no label in reach)."""
import json
import sys
from pathlib import Path

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821

from uqdrive.cli.discover import discover_file
from uqdrive.io import atomic_path, write_dataset
from uqdrive.studies.hidden_effects import benchmark_cases, case_label, generate

config, out = snakemake.params.config, snakemake.output  # noqa: F821
case = {c.name: c for c in benchmark_cases(config, samples=config["discrepancy"]["benchmark"]["samples"])}[snakemake.wildcards.case]  # noqa: F821
write_dataset(generate(config, case), out.measured)
with atomic_path(out.label) as tmp:
    tmp.write_text(json.dumps(case_label(case), indent=2) + "\n")
discover_file(config, Path(out.measured), None, Path(out.verdict), log=lambda line: print(line, file=sys.stderr, flush=True),
              figures=snakemake.params.figures)  # noqa: F821

"""Rule discrepancy_discover: `uqdrive discover` on one measured ensemble (no label in reach)."""
import sys
from pathlib import Path

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821

from uqdrive.cli.discover import discover_file

discover_file(snakemake.params.config, Path(snakemake.input.measured), None, Path(snakemake.output[0]),  # noqa: F821
              log=lambda line: print(line, file=sys.stderr, flush=True), figures=snakemake.params.figures)  # noqa: F821

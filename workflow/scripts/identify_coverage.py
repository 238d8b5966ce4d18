"""Rule identify_coverage: replicate ensembles identified as `uqdrive identify` does; coverage of
the truth by the 95 % intervals per parameter and the misfit test's pass rate."""
import sys
import time

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821

from uqdrive.io import atomic_path
from uqdrive.studies.identification import coverage_study, coverage_table

config = snakemake.params.config  # noqa: F821
c = config["identification"]["coverage"]
t0 = time.perf_counter()
table = coverage_table(coverage_study(config, c["replicates"], c["samples"], dt=c["dt"]))
print(f"{c['replicates']} replicates x {c['samples']} realisations: {time.perf_counter() - t0:.0f} s", file=sys.stderr, flush=True)
with atomic_path(snakemake.output.table) as tmp:  # noqa: F821
    table.round(4).to_csv(tmp, index=False)

"""Rule control_gamma_sweep: SLQR gains and cost parts for each gamma."""
import sys

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821

from uqdrive.studies.control import gamma_sweep
from uqdrive.io import write_dataset

write_dataset(gamma_sweep(snakemake.params.config), snakemake.output[0])  # noqa: F821

"""Rule statistics: mean and std over realisations under the configured spin policy."""
import sys

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821

from uqdrive.io import read_ensemble, write_dataset
from uqdrive.vehicle.statistics import ensemble_statistics

ds = read_ensemble(snakemake.input.ensemble)  # noqa: F821
write_dataset(ensemble_statistics(ds, snakemake.params.spin_policy), snakemake.output[0])  # noqa: F821

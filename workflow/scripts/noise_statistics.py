"""Rule noise_statistics: statistics of the noise-corrupted data sets of Table 5.3 (5.6)."""
import sys

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821

from uqdrive.io import read_ensemble, write_dataset
from uqdrive.rng import rng_stream
from uqdrive.vehicle.statistics import noise_statistics

p = snakemake.params  # noqa: F821
ds = read_ensemble(snakemake.input.ensemble)  # noqa: F821
rngs = [rng_stream(p.seed, "noise", round(A * 1e6)) for A in p.levels]
write_dataset(noise_statistics(ds, p.levels, rngs, p.spin_policy), snakemake.output[0])  # noqa: F821

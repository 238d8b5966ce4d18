"""Rule kle: the side-wind KLE, its eigenfunctions and sample paths (Figs 5.2, 7.1)."""
import sys

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821

from uqdrive.io import write_dataset
from uqdrive.vehicle.montecarlo import wind_kle
from uqdrive.rng import rng_stream
from uqdrive.studies.kle import kle_dataset
from uqdrive.settings import Settings

config = snakemake.params.config  # noqa: F821
settings = Settings.from_config(config)
kle = wind_kle(settings)
t = settings.time.output
ds = kle_dataset(config, kle, t, config["figures"]["kle_realisations"], rng_stream(config["seed"], "kle_figure"))
write_dataset(ds, snakemake.output[0])  # noqa: F821

"""Rule wheelslip_gp: GP of the friction curve from n noisy points, PID design on its slope."""
import sys

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821

from uqdrive.io import write_dataset
from uqdrive.rng import rng_stream
from uqdrive.studies.wheelslip import gp_dataset

config, n = snakemake.params.config, int(snakemake.wildcards.n)  # noqa: F821
write_dataset(gp_dataset(config, n, rng_stream(config["seed"], "wheelslip_gp", n)), snakemake.output[0])  # noqa: F821

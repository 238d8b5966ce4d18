"""Rule wheelslip_closed_loop: braking with the GP-tuned PID on GP posterior friction curves."""
import sys

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821

import xarray as xr

from uqdrive.io import write_dataset
from uqdrive.rng import rng_stream
from uqdrive.studies.wheelslip import closed_loop_dataset

config = snakemake.params.config  # noqa: F821
gp = xr.load_dataset(snakemake.input.gp)  # noqa: F821
write_dataset(closed_loop_dataset(config, gp, rng_stream(config["seed"], "wheelslip_closed_loop")), snakemake.output[0])  # noqa: F821

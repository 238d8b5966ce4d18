"""Rule wheelslip_calibration: coverage of the true slope by the GP 95 % interval."""
import sys

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821

import numpy as np
import xarray as xr

from uqdrive.io import write_dataset
from uqdrive.rng import rng_stream
from uqdrive.studies.wheelslip import calibration_dataset

config, n = snakemake.params.config, int(snakemake.wildcards.n)  # noqa: F821
gp = xr.load_dataset(snakemake.input.gp)  # noqa: F821
hyper = {"v1": gp.attrs["v1"], "g": np.atleast_1d(gp.attrs["g"]), "v0": gp.attrs["v0"]}
rng = rng_stream(config["seed"], "wheelslip_calibration", n)
progress = lambda line: print(line, file=sys.stderr, flush=True)  # noqa: E731
write_dataset(calibration_dataset(config, n, snakemake.params.mcmc_sets, hyper, rng, log=progress), snakemake.output[0])  # noqa: F821

"""Rule control_monte_carlo: the lane-keeping test case with every controller, LST or NLST."""
import sys

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821

import xarray as xr

from uqdrive.studies.control import closed_loop_monte_carlo
from uqdrive.io import write_dataset

config = snakemake.params.config  # noqa: F821
gains = xr.load_dataset(snakemake.input.gains)  # noqa: F821
K = {str(c): gains["K"].sel(controller=c).values for c in gains["controller"].values}
ds = closed_loop_monte_carlo(config, K, snakemake.wildcards.model, config["control"]["samples"], config["seed"])  # noqa: F821
write_dataset(ds, snakemake.output[0])  # noqa: F821

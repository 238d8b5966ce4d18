"""Rule control_gains: LQR (6.1), SLQR (6.2) and the SLQR on the identified distributions."""
import sys

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821

import numpy as np
import xarray as xr

from uqdrive.studies.control import gains_dataset
from uqdrive.io import write_dataset

ident = xr.load_dataset(snakemake.input.identified)  # noqa: F821
theta = np.nanmean(ident["theta"].sel(estimate="NLST-STD").values, axis=0)  # what data from the real car would give
write_dataset(gains_dataset(snakemake.params.config, theta), snakemake.output[0])  # noqa: F821

"""Rule pce_convergence: PCE moment error over N_PCE and quadrature order against Monte Carlo."""
import sys

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821

import xarray as xr

from uqdrive.io import write_dataset
from uqdrive.studies.pce import convergence_study

config = snakemake.params.config  # noqa: F821
conv = config["pce"]["convergence"]
ref = xr.load_dataset(snakemake.input.reference)  # noqa: F821
ds = convergence_study(config, conv["orders"], conv["quadrature_points"], ref["mean"].values, ref["std"].values, ref.attrs["n_samples"])
write_dataset(ds, snakemake.output[0])  # noqa: F821

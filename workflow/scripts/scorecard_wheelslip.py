"""Rule scorecard_wheelslip: the GP paper's published numbers, uqdrive's own GP estimate of
E(Gamma), var(Gamma) against the paper's, and the slope coverage."""
import sys

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821

import xarray as xr

from uqdrive.studies.scorecard import gp_estimate_rows, wheelslip_rows, write_scorecard

config = snakemake.params.config  # noqa: F821
cals = [xr.load_dataset(p) for p in snakemake.input.calibration]  # noqa: F821
write_scorecard(wheelslip_rows(config, cals) + gp_estimate_rows(config, cals), snakemake.output[0])  # noqa: F821

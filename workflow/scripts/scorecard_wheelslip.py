"""Rule scorecard_wheelslip: the GP paper's published numbers and slope coverage."""
import sys

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821

import xarray as xr

from uqdrive.studies.scorecard import wheelslip_rows, write_scorecard

cals = [xr.load_dataset(p) for p in snakemake.input.calibration]  # noqa: F821
write_scorecard(wheelslip_rows(snakemake.params.config, cals), snakemake.output[0])  # noqa: F821

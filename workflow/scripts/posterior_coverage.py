"""Rule posterior_coverage: LST-LST posteriors on independent ensembles; coverage of the truth."""
import sys
import time

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821

import xarray as xr

from uqdrive.studies.bayes import coverage_study
from uqdrive.io import write_dataset
from uqdrive.rng import rng_stream

config = snakemake.params.config  # noqa: F821
b = config["bayes"]
t0 = time.perf_counter()
hits, total, per_set = coverage_study(config, b["calibration_sets"], b["calibration_steps"], rng_stream(config["seed"], "bayes", 99),
                                     log=lambda line: print(f"{time.perf_counter() - t0:.0f} s: {line}", file=sys.stderr, flush=True))
print(f"coverage: {hits} of {total}, {time.perf_counter() - t0:.0f} s", file=sys.stderr, flush=True)
ds = xr.Dataset({"contains_truth": (("set", "parameter"), per_set.reshape(-1, 6))},
                attrs={"hits": hits, "total": total, "title": "coverage of the truth by 95 % posterior intervals (LST-LST)"})
write_dataset(ds, snakemake.output[0])  # noqa: F821

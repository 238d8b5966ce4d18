"""Rule posterior: optimiser estimate and emcee posterior for one case."""
import sys
import time

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821

import xarray as xr

from uqdrive.studies.bayes import CASES, posterior_case, prepare_data
from uqdrive.io import write_dataset
from uqdrive.rng import rng_stream

config, case = snakemake.params.config, snakemake.wildcards.case  # noqa: F821
ens = xr.load_dataset(snakemake.input.ensemble)  # noqa: F821
x, noise_var = prepare_data(config, ens, config["bayes"]["noise_level"] if case.endswith("noise") else 0.0)
t0 = time.perf_counter()
ds = posterior_case(config, x, noise_var, rng_stream(config["seed"], "bayes", CASES.index(case)), progress=False,
                    log=lambda line: print(f"{case}, {time.perf_counter() - t0:.0f} s: {line}", file=sys.stderr, flush=True))
ds.attrs["case"] = case
ds.attrs["seconds"] = time.perf_counter() - t0
print(f"{case}: {ds.attrs['seconds']:.0f} s, tau {ds['tau'].values.max():.0f}, R-hat {ds['r_hat'].values.max():.3f}", file=sys.stderr)
write_dataset(ds, snakemake.output[0])  # noqa: F821

"""Rule mc_reference: mean and std of a large LST Monte Carlo ensemble, in chunks."""
import sys

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821

import xarray as xr

from uqdrive.io import write_dataset
from uqdrive.vehicle.montecarlo import monte_carlo_moments
from uqdrive.vehicle.single_track import STATES
from uqdrive.settings import Settings

config = snakemake.params.config  # noqa: F821
conv = config["pce"]["convergence"]
settings = Settings.from_config(config)
mean, std, n = monte_carlo_moments(settings, "lst", conv["reference_samples"], conv["chunk"])
ds = xr.Dataset(
    {"mean": (("state", "time"), mean), "std": (("state", "time"), std)},
    coords={"state": list(STATES), "time": settings.time.output},
    attrs={"title": "LST Monte Carlo reference moments", "n_samples": n, "seed": config["seed"]},
)
write_dataset(ds, snakemake.output[0])  # noqa: F821

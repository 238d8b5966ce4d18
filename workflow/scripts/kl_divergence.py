"""Rule kl_divergence: D_KL(NLST || LST) of every state over time (Fig 6.6)."""
import sys

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821

import xarray as xr

from uqdrive.io import write_dataset
from uqdrive.vehicle.statistics import kl_divergence_series

lst = xr.load_dataset(snakemake.input.lst)  # noqa: F821
nlst = xr.load_dataset(snakemake.input.nlst)  # noqa: F821
kl = kl_divergence_series(nlst, lst).to_dataset()
kl.attrs.update({"title": "D_KL(NLST || LST) per state and time", "p": "NLST data", "q": "LST data"})
write_dataset(kl, snakemake.output[0])  # noqa: F821

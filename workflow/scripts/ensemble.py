"""Rule ensemble: one Monte Carlo ensemble (thesis sec. 5.1) in the uqdrive data schema."""
import sys

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821

from uqdrive.io import write_dataset
from uqdrive.vehicle.montecarlo import simulate_ensemble
from uqdrive.settings import Settings

w = snakemake.wildcards  # noqa: F821
ds = simulate_ensemble(Settings.from_config(snakemake.params.config), w.model, w.steer)  # noqa: F821
print(f"{w.model} {w.steer}: {ds.attrs['n_spun']} of {ds.sizes['sample']} realisations spun", file=sys.stderr)
write_dataset(ds, snakemake.output[0])  # noqa: F821

"""Rule ensemble: one Monte Carlo ensemble (thesis sec. 5.1) in the uqdrive data schema."""
import sys

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821

from uqdrive.io import write_dataset
from uqdrive.vehicle.montecarlo import simulate_ensemble
from uqdrive.settings import Settings

w = snakemake.wildcards  # noqa: F821
settings = Settings.from_config(snakemake.params.config)  # noqa: F821
experiment = snakemake.params.get("experiment")  # noqa: F821
if experiment:  # an experiment's variant of the car (its rule lists studies.experiments among its sources)
    from uqdrive.studies.experiments import experiment_settings

    settings = experiment_settings(settings, experiment)
ds = simulate_ensemble(settings, w.model, w.steer)
print(f"{w.model} {w.steer}: {ds.attrs['n_spun']} of {ds.sizes['sample']} realisations spun", file=sys.stderr)
write_dataset(ds, snakemake.output[0])  # noqa: F821

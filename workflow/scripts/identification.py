"""Rule identification: one experiment of the thesis (or past it), all runs and estimates."""
import sys

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821

import xarray as xr

from uqdrive.studies.experiments import guess_stream_index
from uqdrive.studies.identification import experiment_plan, measured_data_sets, run_experiment
from uqdrive.io import write_dataset
from uqdrive.rng import rng_stream

name = snakemake.wildcards.experiment  # noqa: F821
config = snakemake.params.config  # noqa: F821
stats = {key: xr.load_dataset(snakemake.input[key]) for key in snakemake.params.stats_keys}  # noqa: F821
data = measured_data_sets(config, stats)
tasks, deviations, m_dev, run_data = experiment_plan(config, name)
rng = rng_stream(config["seed"], "identification", guess_stream_index(name))
ds = run_experiment(config, name, data, tasks, deviations, m_dev, rng, run_data)
ds.attrs["n_spun_excluded_nlst"] = int(stats["nlst_normal"].attrs.get("n_samples", 0) - stats["nlst_normal"].attrs.get("n_used", 0))
write_dataset(ds, snakemake.output[0])  # noqa: F821

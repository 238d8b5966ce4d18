"""Rule stats_no_wind_moment: ensemble statistics with M_c = 0 (the Table 6.2 variant)."""
import sys

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821

from uqdrive.studies.identification import experiment_config
from uqdrive.io import write_dataset
from uqdrive.vehicle.montecarlo import simulate_ensemble
from uqdrive.vehicle.statistics import ensemble_statistics

config = experiment_config(snakemake.params.config, "no_wind_moment")  # noqa: F821
ds = simulate_ensemble(config, snakemake.wildcards.model, "normal")  # noqa: F821
stats = ensemble_statistics(ds, config["montecarlo"]["spin_policy"])
stats.attrs["variant"] = "no wind yaw moment (M_c = 0)"
write_dataset(stats, snakemake.output[0])  # noqa: F821

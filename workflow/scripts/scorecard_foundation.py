"""Rule scorecard_foundation: LQR gain (6.1) and KLE mode count (sec. 7.3)."""
import sys

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821

from uqdrive.vehicle.montecarlo import wind_kle
from uqdrive.studies.scorecard import foundation_rows, write_scorecard
from uqdrive.settings import Settings

config = snakemake.params.config  # noqa: F821
write_scorecard(foundation_rows(config, wind_kle(Settings.from_config(config))), snakemake.output[0])  # noqa: F821

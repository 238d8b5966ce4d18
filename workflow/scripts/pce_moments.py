"""Rule pce_moments: Galerkin PCE of the LST with all uncertainties (Figs 5.3, 5.4)."""
import sys

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821

from uqdrive.io import write_dataset
from uqdrive.studies.pce import pce_dataset
from uqdrive.vehicle.chaos import LSTChaosModel
from uqdrive.settings import Settings

config = snakemake.params.config  # noqa: F821
settings = Settings.from_config(config)
model = LSTChaosModel(settings, order=config["pce"]["order"], quadrature_points=config["pce"]["quadrature_points"])
moments = model.moments(settings.uncertainty.theta(model.uncertain))
write_dataset(pce_dataset(config, model, moments), snakemake.output[0])  # noqa: F821

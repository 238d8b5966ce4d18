"""Rule pce_moments: Galerkin PCE of the LST with all uncertainties (Figs 5.3, 5.4)."""
import sys
from uqdrive.settings import Settings

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821

from uqdrive.io import write_dataset
from uqdrive.studies.pce import pce_dataset
from uqdrive.vehicle.chaos import LSTChaosModel

config = snakemake.params.config  # noqa: F821
model = LSTChaosModel(Settings.from_config(config), order=config["pce"]["order"], quadrature_points=config["pce"]["quadrature_points"])
moments = model.moments(Settings.from_config(config).uncertainty.theta(model.uncertain))
write_dataset(pce_dataset(config, model, moments), snakemake.output[0])  # noqa: F821

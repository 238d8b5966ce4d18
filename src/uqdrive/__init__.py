"""uqdrive: identify, propagate and control the uncertainties of a single-track vehicle.

Polynomial chaos, Monte Carlo ensembles and GP models of the seeds, behind one Snakemake DAG.
What a user needs to fit their own data is importable from here: ``identify``, ``discover`` and
``simulate`` run the commands of the command line on a file or an xarray.Dataset.
"""

from typing import TYPE_CHECKING

from ._lazy import lazy_exports
from ._version import __version__

if TYPE_CHECKING:  # static analysers and the import graph see the real imports
    from .cli.api import Estimate, Verdict, discover, identify, simulate  # noqa: F401
    from .config import load_config  # noqa: F401
    from .inference.identify import DistributionEstimator  # noqa: F401
    from .io import read_ensemble  # noqa: F401
    from .recordings.importer import import_runs  # noqa: F401
    from .settings import Settings  # noqa: F401
    from .vehicle.chaos import LSTChaosModel  # noqa: F401
    from .vehicle.montecarlo import simulate_ensemble  # noqa: F401
    from .vehicle.statistics import ensemble_statistics  # noqa: F401

__getattr__, __dir__ = lazy_exports(__name__, {
    "identify": ".cli.api",
    "discover": ".cli.api",
    "simulate": ".cli.api",
    "Estimate": ".cli.api",
    "Verdict": ".cli.api",
    "load_config": ".config",
    "DistributionEstimator": ".inference.identify",
    "read_ensemble": ".io",
    "import_runs": ".recordings.importer",
    "Settings": ".settings",
    "LSTChaosModel": ".vehicle.chaos",
    "simulate_ensemble": ".vehicle.montecarlo",
    "ensemble_statistics": ".vehicle.statistics",
})

__all__ = [
    "DistributionEstimator",
    "Estimate",
    "LSTChaosModel",
    "Verdict",
    "Settings",
    "__version__",
    "discover",
    "ensemble_statistics",
    "identify",
    "import_runs",
    "load_config",
    "read_ensemble",
    "simulate",
    "simulate_ensemble",
]

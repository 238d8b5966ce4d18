"""uqdrive: identify, propagate and control the uncertainties of a single-track vehicle.

Polynomial chaos, Monte Carlo ensembles and GP models of the seeds, behind one Snakemake DAG.
What a user needs to fit their own data is importable from here.
"""

from typing import TYPE_CHECKING

from ._lazy import lazy_exports
from ._version import __version__

if TYPE_CHECKING:  # static analysers and the import graph see the real imports
    from .config import load_config  # noqa: F401
    from .inference.identify import DistributionEstimator  # noqa: F401
    from .io import read_ensemble  # noqa: F401
    from .recordings.importer import import_runs  # noqa: F401
    from .settings import Settings  # noqa: F401
    from .vehicle.chaos import LSTChaosModel  # noqa: F401
    from .vehicle.montecarlo import simulate_ensemble  # noqa: F401
    from .vehicle.statistics import ensemble_statistics  # noqa: F401

__getattr__, __dir__ = lazy_exports(__name__, {
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
    "LSTChaosModel",
    "Settings",
    "__version__",
    "ensemble_statistics",
    "import_runs",
    "load_config",
    "read_ensemble",
    "simulate_ensemble",
]

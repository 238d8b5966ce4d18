"""uqdrive: identify, propagate and control the uncertainties of a single-track vehicle.

Polynomial chaos, Monte Carlo ensembles and GP models of the seeds, behind one Snakemake DAG.
What a user needs to fit their own data is importable from here.
"""

from ._version import __version__
from .config import load_config
from .inference.identify import DistributionEstimator
from .io import read_ensemble
from .vehicle.chaos import LSTChaosModel
from .vehicle.montecarlo import simulate_ensemble
from .vehicle.statistics import ensemble_statistics

__all__ = [
    "DistributionEstimator",
    "LSTChaosModel",
    "__version__",
    "ensemble_statistics",
    "load_config",
    "read_ensemble",
    "simulate_ensemble",
]

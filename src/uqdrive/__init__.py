"""uqdrive: identify, propagate and control the uncertainties of a single-track vehicle.

Polynomial chaos, Monte Carlo ensembles and GP models of the seeds, behind one Snakemake DAG.
"""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("uqdrive")
except PackageNotFoundError:  # running from a source tree without installation
    __version__ = "0+unknown"

__all__ = ["__version__"]

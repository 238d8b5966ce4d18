"""Inference on ensembles: the distribution estimator (thesis sec. 5.4), identifiability
(sec. 3.2), the emcee posterior, and the discrepancy workflow.
"""

from typing import TYPE_CHECKING

from .._lazy import lazy_exports

if TYPE_CHECKING:  # static analysers and the import graph see the real imports
    from .identify import COSTS, OPTIMISERS, STATE_SCALES, DistributionEstimator, MomentModel  # noqa: F401

__getattr__, __dir__ = lazy_exports(__name__, {
    "COSTS": ".identify",
    "OPTIMISERS": ".identify",
    "STATE_SCALES": ".identify",
    "DistributionEstimator": ".identify",
    "MomentModel": ".identify",
})

__all__ = ["COSTS", "OPTIMISERS", "STATE_SCALES", "DistributionEstimator", "MomentModel"]

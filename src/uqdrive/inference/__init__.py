"""Inference on ensembles: the distribution estimator (thesis sec. 5.4), identifiability
(sec. 3.2), the emcee posterior, and the discrepancy workflow.
"""

from .identify import COSTS, OPTIMISERS, STATE_SCALES, DistributionEstimator, MomentModel

__all__ = ["COSTS", "OPTIMISERS", "STATE_SCALES", "DistributionEstimator", "MomentModel"]

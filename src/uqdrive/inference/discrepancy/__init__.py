"""The discrepancy workflow (past the thesis): localise where measured data leave a calibrated
null band of the best baseline, name the missing physical effect, add it, show the gap shrink.
"""

from .band import NullBand, excess_rms
from .finder import DEFAULT_CANDIDATES, DiscrepancyFinder, family_of

__all__ = ["DEFAULT_CANDIDATES", "DiscrepancyFinder", "NullBand", "excess_rms", "family_of"]

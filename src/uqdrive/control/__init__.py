"""Lane-keeping control: LQR on the mean model and the stochastic LQR on the closed-loop PCE
(thesis sec. 4.4, 5.5).
"""

from .lqr import lqr_gain
from .slqr import ClosedLoopChaos, LaneKeepingCase

__all__ = ["ClosedLoopChaos", "LaneKeepingCase", "lqr_gain"]

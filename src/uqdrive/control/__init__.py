"""Lane-keeping control: LQR on the mean model and the stochastic LQR on the closed-loop PCE
(thesis sec. 4.4, 5.5).
"""

from typing import TYPE_CHECKING

from .._lazy import lazy_exports

if TYPE_CHECKING:  # static analysers and the import graph see the real imports
    from .lqr import lqr_gain  # noqa: F401
    from .slqr import ClosedLoopChaos, LaneKeepingCase  # noqa: F401

__getattr__, __dir__ = lazy_exports(__name__, {
    "lqr_gain": ".lqr",
    "ClosedLoopChaos": ".slqr",
    "LaneKeepingCase": ".slqr",
})

__all__ = ["ClosedLoopChaos", "LaneKeepingCase", "lqr_gain"]

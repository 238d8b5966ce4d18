"""The second seed: GP model of the tyre friction curve with slope uncertainty, the quarter car,
and the robust wheel-slip PID design (paper eqs. (6)-(27)).
"""

from typing import TYPE_CHECKING

from .._lazy import lazy_exports

if TYPE_CHECKING:  # static analysers and the import graph see the real imports
    from .gp import ArcsineGP  # noqa: F401
    from .quarter_car import QuarterCar, friction_curve, pid_gains  # noqa: F401

__getattr__, __dir__ = lazy_exports(__name__, {
    "ArcsineGP": ".gp",
    "QuarterCar": ".quarter_car",
    "friction_curve": ".quarter_car",
    "pid_gains": ".quarter_car",
})

__all__ = ["ArcsineGP", "QuarterCar", "friction_curve", "pid_gains"]

"""The second seed: GP model of the tyre friction curve with slope uncertainty, the quarter car,
and the robust wheel-slip PID design (paper eqs. (6)-(27)).
"""

from .gp import ArcsineGP
from .quarter_car import QuarterCar, friction_curve, pid_gains

__all__ = ["ArcsineGP", "QuarterCar", "friction_curve", "pid_gains"]

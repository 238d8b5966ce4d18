"""The hidden-effect benchmark's reality (right-hand side and integrator)."""

from .reality import reality_rhs, rk4_left_limit, speed_of_case

__all__ = ["reality_rhs", "rk4_left_limit", "speed_of_case"]

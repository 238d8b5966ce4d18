"""The hidden-effect benchmark's reality (right-hand side and integrator)."""

from .reality import CHASSIS_EFFECTS, case_speed, reality_rhs, rk4_left_limit, speed_of_case, state_size

__all__ = ["CHASSIS_EFFECTS", "case_speed", "reality_rhs", "rk4_left_limit", "speed_of_case", "state_size"]

"""Measured ensembles of the four-wheel reality for the discovery benchmark."""

from .cases import FourWheelCase, amplitude_for, case_label, four_wheel_cases, generate, simulate_case, steady_limit

__all__ = ["FourWheelCase", "amplitude_for", "case_label", "four_wheel_cases", "generate", "simulate_case", "steady_limit"]

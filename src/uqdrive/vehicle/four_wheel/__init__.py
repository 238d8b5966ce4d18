"""An independent four-wheel vehicle model (the reality of the four-wheel discovery benchmark),
written apart from the single-track models under test."""

from .model import N_STATES, FourWheelCar, FourWheelRHS, simulate_four_wheel

__all__ = ["N_STATES", "FourWheelCar", "FourWheelRHS", "simulate_four_wheel"]

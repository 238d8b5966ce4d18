"""Independent realities for the discovery benchmarks, written apart from the models under test."""

from .pacejka_roll import RollingCar
from .pacejka_single_track import PacejkaCar, simulate_pacejka

__all__ = ["PacejkaCar", "RollingCar", "simulate_pacejka"]

"""Measured ensembles of the Pacejka single-track reality for the real-tyres discovery benchmark."""

from .cases import CARS, REAL_TYRE_CASES, RealTyreCase, amplitude_for, case_label, generate, real_tyre_cases, simulate_case, steady_limit

__all__ = ["CARS", "REAL_TYRE_CASES", "RealTyreCase", "amplitude_for", "case_label", "generate", "real_tyre_cases", "simulate_case", "steady_limit"]

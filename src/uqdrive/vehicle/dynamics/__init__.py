"""The single-track model's dynamics written once: the non-linear right-hand side with the inputs
it reads per RK4 half step, and the ensemble integrators every simulator of the package calls.
"""

from typing import TYPE_CHECKING

from ..._lazy import lazy_exports

if TYPE_CHECKING:  # static analysers and the import graph see the real imports
    from .engine import EnsembleSimulator, HalfStepDrive  # noqa: F401
    from .ensemble import exact_response, lateral_acceleration, simulate_lst, simulate_lst_ltv  # noqa: F401
    from .rhs import GustInputs, HalfStepInputs, SingleTrackRHS, nlst_rhs  # noqa: F401

__getattr__, __dir__ = lazy_exports(__name__, {
    "GustInputs": ".rhs",
    "HalfStepInputs": ".rhs",
    "SingleTrackRHS": ".rhs",
    "nlst_rhs": ".rhs",
    "EnsembleSimulator": ".engine",
    "HalfStepDrive": ".engine",
    "exact_response": ".ensemble",
    "lateral_acceleration": ".ensemble",
    "simulate_lst": ".ensemble",
    "simulate_lst_ltv": ".ensemble",
})

__all__ = ["EnsembleSimulator", "HalfStepDrive", "GustInputs", "HalfStepInputs", "SingleTrackRHS", "nlst_rhs", "exact_response", "lateral_acceleration", "simulate_lst",
           "simulate_lst_ltv"]

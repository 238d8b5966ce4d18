"""The non-linear single-track model's right-hand side, written once, and the inputs it reads per
RK4 half step: what every non-linear simulator of the package integrates.
"""

from typing import TYPE_CHECKING

from ..._lazy import lazy_exports

if TYPE_CHECKING:  # static analysers and the import graph see the real imports
    from .rhs import GustInputs, HalfStepInputs, SingleTrackRHS, nlst_rhs  # noqa: F401

__getattr__, __dir__ = lazy_exports(__name__, {
    "GustInputs": ".rhs",
    "HalfStepInputs": ".rhs",
    "SingleTrackRHS": ".rhs",
    "nlst_rhs": ".rhs",
})

__all__ = ["GustInputs", "HalfStepInputs", "SingleTrackRHS", "nlst_rhs"]

"""The Monte Carlo ensemble simulator on an accelerator: the NLST's right-hand sides and RK4 in
JAX (float64), the same numbers as the NumPy path of :mod:`uqdrive.vehicle.montecarlo`.
"""

from typing import TYPE_CHECKING

from ..._lazy import lazy_exports

if TYPE_CHECKING:  # static analysers and the import graph see the real imports
    from .nlst import nlst_program, simulate_nlst_jax  # noqa: F401

__getattr__, __dir__ = lazy_exports(__name__, {
    "nlst_program": ".nlst",
    "simulate_nlst_jax": ".nlst",
})

__all__ = ["nlst_program", "simulate_nlst_jax"]

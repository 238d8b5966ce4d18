"""The ensemble simulators on an accelerator, by JAX in float64: the NLST's Monte Carlo ensembles
(:mod:`uqdrive.vehicle.accelerated.nlst`) and the single-track model with chassis effects that
discover fits (:mod:`uqdrive.vehicle.accelerated.chassis_ensemble`), each the NumPy path's numbers to 1e-10.
"""

from typing import TYPE_CHECKING

from ..._lazy import lazy_exports

if TYPE_CHECKING:  # static analysers and the import graph see the real imports
    from .chassis import chassis_constants, chassis_lateral_acceleration, chassis_rates  # noqa: F401
    from .chassis_ensemble import integrate_chassis_jax, programs_compiled, switched_on  # noqa: F401
    from .nlst import nlst_program, simulate_nlst_jax  # noqa: F401
    from .rk4 import per_step, rk4_rows_step  # noqa: F401

__getattr__, __dir__ = lazy_exports(__name__, {
    "nlst_program": ".nlst",
    "simulate_nlst_jax": ".nlst",
    "chassis_constants": ".chassis",
    "chassis_rates": ".chassis",
    "chassis_lateral_acceleration": ".chassis",
    "integrate_chassis_jax": ".chassis_ensemble",
    "programs_compiled": ".chassis_ensemble",
    "switched_on": ".chassis_ensemble",
    "rk4_rows_step": ".rk4",
    "per_step": ".rk4",
})

__all__ = ["nlst_program", "simulate_nlst_jax", "chassis_constants", "chassis_rates", "chassis_lateral_acceleration", "integrate_chassis_jax",
           "programs_compiled", "switched_on", "rk4_rows_step", "per_step"]

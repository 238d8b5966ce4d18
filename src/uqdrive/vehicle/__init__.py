"""The car and its uncertainties: single-track models (thesis (5.3), (5.4)), germ maps and the
wind KLE, Monte Carlo ensembles, measurement noise, ensemble statistics and the LST's chaos model.
"""

from typing import TYPE_CHECKING

from .._lazy import lazy_exports

if TYPE_CHECKING:  # static analysers and the import graph see the real imports
    from .chaos import ChaosMoments, LSTChaosModel  # noqa: F401
    from .montecarlo import simulate_ensemble  # noqa: F401
    from .dynamics.rhs import nlst_rhs  # noqa: F401
    from .single_track import STATES, VehicleParameters, lst_matrices, steering_input  # noqa: F401
    from .statistics import ensemble_statistics  # noqa: F401

__getattr__, __dir__ = lazy_exports(__name__, {
    "ChaosMoments": ".chaos",
    "LSTChaosModel": ".chaos",
    "simulate_ensemble": ".montecarlo",
    "STATES": ".single_track",
    "VehicleParameters": ".single_track",
    "lst_matrices": ".single_track",
    "nlst_rhs": ".dynamics.rhs",
    "steering_input": ".single_track",
    "ensemble_statistics": ".statistics",
})

__all__ = [
    "STATES",
    "ChaosMoments",
    "LSTChaosModel",
    "VehicleParameters",
    "ensemble_statistics",
    "lst_matrices",
    "nlst_rhs",
    "simulate_ensemble",
    "steering_input",
]

"""The car and its uncertainties: single-track models (thesis (5.3), (5.4)), germ maps and the
wind KLE, Monte Carlo ensembles, measurement noise, ensemble statistics and the LST's chaos model.
"""

from .chaos import ChaosMoments, LSTChaosModel
from .montecarlo import simulate_ensemble
from .single_track import STATES, VehicleParameters, lst_matrices, nlst_rhs, steering_input
from .statistics import ensemble_statistics

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

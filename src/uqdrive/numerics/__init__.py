"""Numerical core: pure functions on arrays (integration, linear recursions, matrix
exponentials and their derivatives, orthogonal polynomials, PCE, Galerkin projection, metrics).
"""

from .galerkin import GalerkinProjector
from .metrics import kl_divergence_normal, normalised_w2_normal, normalised_w2_uniform, wasserstein2_normal, wasserstein2_uniform
from .pce import PolynomialChaos

__all__ = [
    "GalerkinProjector",
    "PolynomialChaos",
    "kl_divergence_normal",
    "normalised_w2_normal",
    "normalised_w2_uniform",
    "wasserstein2_normal",
    "wasserstein2_uniform",
]

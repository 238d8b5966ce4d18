"""Numerical core: pure functions on arrays (integration, linear recursions, matrix
exponentials and their derivatives, orthogonal polynomials, PCE, Galerkin projection, metrics,
sampled inputs).
"""

from typing import TYPE_CHECKING

from .._lazy import lazy_exports

if TYPE_CHECKING:  # static analysers and the import graph see the real imports
    from .galerkin import GalerkinProjector  # noqa: F401
    from .metrics import kl_divergence_normal, normalised_w2_normal, normalised_w2_uniform, wasserstein2_normal, wasserstein2_uniform  # noqa: F401
    from .pce import PolynomialChaos  # noqa: F401

__getattr__, __dir__ = lazy_exports(__name__, {
    "GalerkinProjector": ".galerkin",
    "kl_divergence_normal": ".metrics",
    "normalised_w2_normal": ".metrics",
    "normalised_w2_uniform": ".metrics",
    "wasserstein2_normal": ".metrics",
    "wasserstein2_uniform": ".metrics",
    "PolynomialChaos": ".pce",
})

__all__ = [
    "GalerkinProjector",
    "PolynomialChaos",
    "kl_divergence_normal",
    "normalised_w2_normal",
    "normalised_w2_uniform",
    "wasserstein2_normal",
    "wasserstein2_uniform",
]

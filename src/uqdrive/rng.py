"""Named, reproducible random streams: every random quantity of uqdrive draws from its own
child of the root seed (numpy SeedSequence), so adding one stream never changes another.
"""

from __future__ import annotations

import numpy as np

__all__ = ["STREAMS", "rng_stream"]

#: Fixed stream identifiers; e.g. the LST and NLST ensembles of one seed share "parameters".
STREAMS = {
    "parameters": 1,
    "wind": 2,
    "noise": 3,
    "kle_figure": 4,
    "wheelslip_gp": 5,
    "wheelslip_calibration": 6,
    "wheelslip_closed_loop": 7,
    "identification": 8,
    "control": 9,
    "bayes": 10,
    "hidden_parameters": 11, "hidden_wind": 12, "hidden_noise": 13,
    "discrepancy_model": 20,
    "discrepancy_bootstrap": 21,
    "discrepancy_posterior": 22,
    "identify_reference": 40,   # multiplier bootstrap of the misfit's reference (goodness of fit)
    "identify_coverage": 41,    # starts of the error-bar calibration's replicate fits
}


def rng_stream(seed: int, stream: str, *keys: int) -> np.random.Generator:
    """Independent generator for a named stream of the root ``seed``, with optional int keys."""
    if stream not in STREAMS:
        raise ValueError(f"unknown random stream '{stream}'; known: {', '.join(STREAMS)}")
    return np.random.default_rng(np.random.SeedSequence([int(seed), STREAMS[stream], *map(int, keys)]))

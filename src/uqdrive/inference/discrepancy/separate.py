"""Which steering input would tell two candidate effects apart that the measured data cannot
(past the thesis): each candidate, with the distributions and effect parameters it was fitted
with, predicts the mean and std trajectories under every proposed input; the input whose two
predictions differ most, in units of the null band of an experiment of the same size, is the one
to drive next.

The inputs are arrays on the measured time grid, supplied by the caller (the CLI builds them from
:mod:`uqdrive.studies.manoeuvres`), so this module stays below the studies layer.
"""

from __future__ import annotations

from typing import Mapping

import numpy as np

from .effectset import family_of
from .fit import StructureFit

__all__ = ["separation", "predicted_statistics", "suggest_input", "separating_inputs"]


def separation(stats_a, stats_b, n: int, model_samples: int, floor: float = 1e-3) -> float:
    """Squared distance of two predictions in units of the null band of an n-realisation experiment.

    The band's scale of a statistic is the sampling standard deviation its estimate would have:
    s / sqrt(n) for the mean, s / sqrt(2 n) for the std (Gaussian approximation), both times
    sqrt(1 + n / M) for a model of M realisations; s is the two predictions' average std
    (measurement noise included), floored at ``floor`` of each row's largest value.

    Parameters
    ----------
    stats_a, stats_b : ndarray, shape (2, 4, K)
        Predicted [mean, std] per state and time.
    n, model_samples : int

    Returns
    -------
    float
        sum(z^2) over statistics, states and times: the expected chi-square by which the wrong
        candidate would misfit data of that experiment (0: the input cannot separate them).
    """
    a, b = np.asarray(stats_a, float), np.asarray(stats_b, float)
    s = 0.5 * (a[1] + b[1])
    scale = np.stack([s / np.sqrt(n), s / np.sqrt(2.0 * n)]) * np.sqrt(1.0 + n / model_samples)
    top = scale.max(axis=-1, keepdims=True)
    scale = np.maximum(scale, floor * np.where(top > 0, top, 1.0))
    return float(np.sum(((a - b) / scale) ** 2))


def predicted_statistics(fit: StructureFit, delta) -> np.ndarray:
    """[mean, std] (2, 4, K) that ``fit``'s model (its estimate, effect and noise) predicts when
    the car is steered by ``delta`` (commanded angle on the fit's data grid, rad)."""
    other = StructureFit(fit.simulator.with_input(delta), fit.index, fit.noise_variance, fit.spin_threshold, fit.effect, fit.base, fixed=fit.fixed)
    return other.statistics(fit.theta_, fit.structure_)


def suggest_input(fits: Mapping[str, StructureFit], pairs, inputs: Mapping[str, np.ndarray], n: int) -> list[dict]:
    """For each pair of candidates, the input that separates them best.

    Parameters
    ----------
    fits : mapping of str to StructureFit
        Fitted candidates (registry name -> joint fit on the measured data).
    pairs : sequence of (str, str)
        Candidate pairs the data could not tell apart.
    inputs : mapping of str to ndarray, shape (T,)
        Proposed steering commands on the measured grid (rad); ``"measured"`` may be among them.
    n : int
        Realisations of the proposed experiment (the measured count).

    Returns
    -------
    list of dict
        Per pair: ``candidates``, ``input`` (the best), ``separation`` (its chi-square, see
        :func:`separation`), ``by_input`` {input: chi-square}.
    """
    cache: dict = {}

    def stats(name, key):
        if (name, key) not in cache:
            cache[name, key] = predicted_statistics(fits[name], inputs[key])
        return cache[name, key]

    out = []
    for a, b in pairs:
        M = min(fits[a].simulator.germs.n, fits[b].simulator.germs.n)
        scores = {key: round(separation(stats(a, key), stats(b, key), n, M), 2) for key in inputs}
        best = max(scores, key=scores.get)
        out.append({"candidates": [a, b], "input": best, "separation": scores[best], "by_input": scores})
    return out


def separating_inputs(fits, named: str, ambiguous, inputs, measured, n: int) -> list:
    """Per candidate of ``fits`` whose family is among ``ambiguous`` (those the named effect
    ``named`` ties with): the input of ``inputs`` (name -> steering command, rad) or the
    ``measured`` one that tells it from ``named`` best (:func:`suggest_input`, ``n`` realisations).
    Empty without such a candidate or without proposed inputs."""
    families = set(ambiguous)
    pairs = [(named, c) for c in fits if c != named and family_of(c) in families]
    if not (pairs and inputs):
        return []
    return suggest_input(fits, pairs, {"measured": measured, **dict(inputs)}, n)

"""The identification experiments by name: which exist, the config each runs with and the figures
that show them. Plain Python on purpose: the workflow imports it while it parses its rules."""

from __future__ import annotations

import copy
from dataclasses import replace
from types import MappingProxyType
from typing import TYPE_CHECKING, Any, Mapping

if TYPE_CHECKING:
    from ..settings import Settings

__all__ = ["EXPERIMENTS", "PAIRED_WITH", "guess_stream_index", "experiment_settings", "experiment_provenance", "NLST_ESTIMATES",
           "FIGURE_NAMES", "APPENDIX_B_PLAN"]

#: The thesis' four experiments (Section 6.2) and uqdrive's variants of them, in stream order.
EXPERIMENTS = ("basic", "inverted", "initial_guess", "noise", "robust", "no_wind_moment", "normalised", "normalised_inverted")

#: Variants that start from the same initial guesses as the experiment they vary (paired runs).
PAIRED_WITH = {"normalised": "basic", "normalised_inverted": "inverted"}

NLST_ESTIMATES = ("NLST-STD", "NLST-INP", "NLST-DST")
#: File stems of the chapter-6 figures (and the robust-start one) the identification figures draw.
FIGURE_NAMES = tuple(f"fig_6_{k}" for k in range(7, 16)) + ("fig_robust_start",)
_FOUR = ("LST-STD",) + NLST_ESTIMATES
#: (experiment, estimate) of Figs B.1-B.13, in order.
APPENDIX_B_PLAN = tuple(
    [("basic", e) for e in _FOUR] + [("initial_guess", e) for e in _FOUR]
    + [("noise", e) for e in NLST_ESTIMATES] + [("inverted", e) for e in NLST_ESTIMATES[1:]]
)


def guess_stream_index(name: str) -> int:
    """Index of the random stream of an experiment's initial guesses (shared by paired variants)."""
    return EXPERIMENTS.index(PAIRED_WITH.get(name, name))


#: The yaw moment per unit side force (m) of the variant without the wind's yaw moment: thesis
#: Table 6.2's LST row is reproduced only so (see docs/reproduction.md).
NO_WIND_MOMENT_M_C = 0.0


def experiment_settings(settings: Settings, name: str) -> Settings:
    """The settings an experiment runs with: those of the config, but M_c = :data:`NO_WIND_MOMENT_M_C`
    for ``no_wind_moment``, whose ensembles' provenance records it too (:func:`experiment_provenance`)."""
    if name != "no_wind_moment":
        return settings
    prov = settings.ensemble_provenance
    return replace(settings, vehicle=replace(settings.vehicle, M_c=NO_WIND_MOMENT_M_C),
                   ensemble_provenance=None if prov is None else MappingProxyType(experiment_provenance(prov, name)))


def experiment_provenance(config: Mapping[str, Any], name: str) -> dict:
    """What an experiment's outputs record as their settings (their ``config_hash``): ``config``
    with the values the experiment fixes (:func:`experiment_settings`)."""
    cfg = copy.deepcopy(dict(config))
    if name == "no_wind_moment":
        cfg["vehicle"] = dict(cfg["vehicle"], M_c=NO_WIND_MOMENT_M_C)
    return cfg

"""The terms of the augmented single-track model that a :class:`~.structure.ModelStructure`
parametrises: each term's fields, when it is on, whether it needs the chassis right-hand side or
numerical integration, and the RK4 step it needs. The one place that says which terms are active.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

__all__ = ["Term", "TERMS", "CHASSIS_FIELDS", "term_of"]


def _nonzero(value) -> bool:
    return bool(np.any(np.asarray(value) != 0))


def _positive(value) -> bool:
    return bool(np.any(np.asarray(value) > 0))


def _not_one(value) -> bool:
    return bool(np.any(np.asarray(value) != 1))


def _saturating(value) -> bool:
    return value != "linear"


def _slip_lag_step(s, v: float) -> float:
    """sigma / v: |h lambda| <= 1 for the slip angles' first-order lag (largest sigma of a batch)."""
    sigma = float(np.max(s.relaxation_length))
    return sigma / float(v) if sigma > 0 else np.inf


def _roll_mode_step(s, v: float) -> float:
    """1 / omega of the roll mode the roll steer follows (fastest of a batch)."""
    return 1.0 / (2 * np.pi * float(np.max(s.roll_frequency)))


@dataclass(frozen=True)
class Term:
    """One term of the right-hand side.

    Attributes
    ----------
    name : str
    fields : tuple of str
        The :class:`~.structure.ModelStructure` fields that parametrise it.
    switches : tuple of (str, callable)
        (field, rule): the term is on when a rule holds for its field's value (a scalar, or one
        value per realisation in a batch); all off: the thesis' LST (5.4).
    chassis : bool
        When on, the model is integrated with the chassis right-hand side
        (:mod:`uqdrive.vehicle.track_extended`).
    integrated : bool
        When on, the model has no exact discretisation: numerical integration (RK4).
    step : callable or None
        (structure, v in m/s) -> the largest RK4 step (s) the term allows when on.
    """

    name: str
    fields: tuple
    switches: tuple = ()
    chassis: bool = False
    integrated: bool = False
    step: Callable | None = None

    def switched(self, structure) -> tuple:
        """Whether each switch is on (bools, in ``switches`` order)."""
        return tuple(rule(getattr(structure, field)) for field, rule in self.switches)

    def active(self, structure) -> bool:
        """Whether the term is on in ``structure``."""
        return any(rule(getattr(structure, field)) for field, rule in self.switches)


#: The model's terms; every field of ModelStructure (but the provenance ``effects``) is in one.
TERMS = (
    Term("actuator", ("steering_lag", "steering_delay"), (("steering_lag", _positive), ("steering_delay", _positive))),
    Term("tyre", ("tyre", "tyre_curvature", "tyre_stiffness_factor", "tyre_shape_factor"), (("tyre", _saturating),), integrated=True),
    Term("kinematics", ("course_weight", "course_exact"), (("course_weight", _nonzero), ("course_exact", _nonzero))),
    Term("disturbance", ("lateral_acceleration", "gust_scale"), (("lateral_acceleration", _nonzero), ("gust_scale", _not_one))),
    Term("load_transfer", ("pitch_height", "load_sensitivity", "roll_share_front"),
         (("pitch_height", _nonzero), ("load_sensitivity", _nonzero)), chassis=True, integrated=True),
    Term("compliance_steer", ("compliance_steer",), (("compliance_steer", _nonzero),), chassis=True),
    Term("relaxation", ("relaxation_length",), (("relaxation_length", _positive),), chassis=True, integrated=True, step=_slip_lag_step),
    Term("roll_steer", ("roll_steer", "roll_frequency", "roll_damping"), (("roll_steer", _nonzero),), chassis=True, integrated=True,
         step=_roll_mode_step),
    Term("combined_slip", ("combined_slip", "drive_share_front"), (("combined_slip", _nonzero),), chassis=True, integrated=True),
    Term("load_sensitive_tyre", ("stiffness_load_sensitivity", "peak_load_sensitivity"),
         (("stiffness_load_sensitivity", _nonzero), ("peak_load_sensitivity", _nonzero)), chassis=True, integrated=True),
    Term("sensors", ("output_offset", "output_gain", "a_y_offset", "a_y_gain"),
         (("output_offset", _nonzero), ("output_gain", _not_one), ("a_y_offset", _nonzero), ("a_y_gain", _not_one))),
)

#: The fields of the chassis terms (one value per realisation in a batch of structures).
CHASSIS_FIELDS = tuple(f for t in TERMS if t.chassis for f in t.fields)


def term_of(field: str) -> Term:
    """The term a :class:`~.structure.ModelStructure` field parametrises."""
    for t in TERMS:
        if field in t.fields:
            return t
    raise KeyError(f"no term has the field '{field}'")

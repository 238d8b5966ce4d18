"""The model structure a candidate effect sets and the candidate effect's base class: what
:mod:`uqdrive.vehicle.augmented` simulates, and how a named effect with its parameters sets it.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import ClassVar

import numpy as np

from ...settings import Vehicle
from ..single_track import STATES
from .terms import TERMS

__all__ = ["ModelStructure", "Effect"]


@dataclass(frozen=True)
class ModelStructure:
    """How the single-track model is built; the defaults are the thesis' LST (5.4). Each field
    parametrises one term of the right-hand side (:data:`~.terms.TERMS`), which says when it is on.

    Attributes
    ----------
    tyre : {"linear", "magic_formula"}
        Linear tyre forces c alpha (5.4), or Pacejka's Magic Formula (2.2) as in the NLST (5.3).
    tyre_curvature : float or None
        Magic-Formula curvature factor E (-); None takes ``tyre.E`` of the config.
    steering_lag : float
        Time constant (s) of a first-order lag between commanded and actual steering angle.
    steering_delay : float
        Dead time (s) between commanded and actual steering angle.
    lateral_acceleration : float
        Constant lateral acceleration (m/s^2) on the body without yaw moment (road bank: g sin phi).
    gust_scale : float
        Factor on the configured gust standard deviation F_w,sigma (-).
    course_weight : float
        k in y_dot = v (psi + k beta): 0 is the thesis' heading kinematics, 1 the course angle.
    course_exact : bool
        y_dot = v sin(psi + k beta), the exact course kinematics, instead of its linearisation
        (set by ``lateral_kinematics``; the numerically integrated model always has the sine).
    output_offset, output_gain : tuple of 4 floats
        Measured channel = gain * state + offset, per state (psi, psi_dot, beta, y), SI units.
    effects : tuple of (name, parameters)
        The named effects that built this structure, for provenance and ``model.yaml``.
    pitch_height : float
        Centre-of-gravity height h (m) of the longitudinal load transfer
        F_zf = m (g l_r - a_x h) / L; 0: static axle loads.
    load_sensitivity : float
        Tyre load sensitivity p_Dz (-) of the peak mu F_z (1 + p_Dz dfz); 0: forces proportional
        to the load (then the lateral load transfer has no effect).
    roll_share_front : float
        Front share chi_f (-) of the lateral load transfer h T / t, T the tyres' lateral force (roll-stiffness distribution).
    compliance_steer : float
        Front steer angle change per g of the front axle's force over its static load (deg/g;
        at steady cornering per g of lateral acceleration), positive: out of the turn.
    relaxation_length : float
        Tyre relaxation length sigma (m) of a first-order lag of the slip angles; 0: none.
    roll_steer : float
        Front steer angle change per g of the tyres' lateral force over the base mass m_base
        (deg/g) through the body's roll, positive: out of the turn; 0: none.
    roll_frequency, roll_damping : float
        Natural frequency (Hz) and damping ratio (-) of the roll mode the roll steer follows.
    combined_slip, drive_share_front : float
        Friction-ellipse weight kappa (-) of the longitudinal force (0: none) and chi_d (-) (:class:`CombinedSlip`).
    stiffness_load_sensitivity, peak_load_sensitivity : float
        q (-) and p_Dz (-) of the load-sensitive tyre: axle i's cornering stiffness and peak times
        1 + q dfz_i and 1 + p_Dz dfz_i, dfz_i its relative load change by the longitudinal
        acceleration at the car's cg_height (``pitch_height`` where set); 0, 0: none.
    tyre_stiffness_factor : float
        b (-): factor on the car's Magic-Formula stiffness factors B_f and B_r (the tyre's own shape); 1: the car's.
    tyre_shape_factor : float or None
        The Magic-Formula shape factor C (-); None takes the car's ``C``.
    a_y_offset, a_y_gain : float
        Measured lateral acceleration = gain * a_y + offset (m/s^2, -): the accelerometer's own
        bias and scale error (the states' are in ``output_offset``, ``output_gain``).
    """

    tyre: str = "linear"
    tyre_curvature: float | None = None
    steering_lag: float = 0.0
    steering_delay: float = 0.0
    lateral_acceleration: float = 0.0
    gust_scale: float = 1.0
    course_weight: float = 0.0
    course_exact: bool = False
    output_offset: tuple = (0.0, 0.0, 0.0, 0.0)
    output_gain: tuple = (1.0, 1.0, 1.0, 1.0)
    effects: tuple = field(default=())
    pitch_height: float = 0.0
    load_sensitivity: float = 0.0
    roll_share_front: float = 0.5
    compliance_steer: float = 0.0
    relaxation_length: float = 0.0
    roll_steer: float = 0.0
    roll_frequency: float = 2.0
    roll_damping: float = 0.6
    a_y_offset: float = 0.0
    a_y_gain: float = 1.0
    combined_slip: float = 0.0
    drive_share_front: float = 0.0
    stiffness_load_sensitivity: float = 0.0
    peak_load_sensitivity: float = 0.0
    tyre_stiffness_factor: float = 1.0
    tyre_shape_factor: float | None = None

    def tyre_shape(self) -> tuple[float, float | None]:
        """(b, C) of the tyre's own shape: what a :class:`~uqdrive.vehicle.single_track.VehicleParameters`
        takes from the structure (B_f, B_r times b; C unless None)."""
        return float(self.tyre_stiffness_factor), None if self.tyre_shape_factor is None else float(self.tyre_shape_factor)

    def output_map(self, channels=STATES) -> tuple[np.ndarray, np.ndarray]:
        """Gain and offset (each shape (C,)) of the measured ``channels`` (names of
        :data:`uqdrive.vehicle.channels.CHANNELS`): measured = gain * true + offset."""
        gain = [self.a_y_gain if c == "a_y" else self.output_gain[STATES.index(c)] for c in channels]
        offset = [self.a_y_offset if c == "a_y" else self.output_offset[STATES.index(c)] for c in channels]
        return np.asarray(gain, float), np.asarray(offset, float)

    @property
    def active_terms(self) -> tuple[str, ...]:
        """Names of the terms switched on (:data:`~.terms.TERMS`); () is the thesis' LST."""
        return tuple(t.name for t in TERMS if t.active(self))

    @property
    def nonlinear(self) -> bool:
        """True when the model needs numerical integration (no exact discretisation): a
        Magic-Formula tyre, load transfer, tyre relaxation, roll steer, combined slip or a
        load-sensitive tyre (compliance steer alone is linear: a softer front axle)."""
        return any(t.integrated and t.active(self) for t in TERMS)

    @property
    def uses_chassis(self) -> bool:
        """True when a chassis term is on (load transfer, relaxation, compliance or roll steer,
        combined slip, the load-sensitive tyre): integrated with the chassis right-hand side."""
        return any(t.chassis and t.active(self) for t in TERMS)

    def chassis_switches(self) -> tuple[bool, ...]:
        """Which switches of the chassis terms are on: structures that agree share a chassis pass."""
        return tuple(on for t in TERMS if t.chassis for on in t.switched(self))

    def max_step(self, v: float, max_step: float) -> float:
        """Largest RK4 step (s): ``max_step``, or less where an active term needs it (the slip
        lag sigma / v, the roll mode 1 / omega) at the speed ``v`` (m/s)."""
        step = max_step
        for t in TERMS:
            if t.step is not None and t.active(self):
                step = min(step, t.step(self, v))
        return step


@dataclass(frozen=True)
class Effect:
    """A physical effect with named parameters, their bounds, start values and units.

    Subclasses implement :meth:`apply` (how the parameters enter the :class:`ModelStructure`).
    ``signature`` says in words which statistics the effect moves first; it is what a reader of
    the verdict needs to judge a candidate, not an input to the ranking (the fits rank them).
    ``requires``: the car's optional constants (``cg_height``, ...) it needs; without them it is untestable.

    Two facts of the effect's physics, set by each subclass: ``vanishes``, (parameter, value) at
    which the effect vanishes (the baseline's model; a named effect must have a size the data tell
    from it; None where no value does: the Magic Formula's curvature E differs from the linear
    tyre at every E), and ``physical``, (parameter, value) where a parameter has one value by its
    physics (the exact course angle's k = 1; discovery judges the effect there).
    """

    vanishes: ClassVar[tuple | None] = None
    physical: ClassVar[tuple | None] = None

    name: str
    parameters: tuple
    units: tuple
    bounds: tuple
    start: tuple
    description: str
    signature: str
    requires: tuple = field(default=(), kw_only=True)

    def missing(self, vehicle: Vehicle | None) -> tuple:
        """The constants of ``requires`` that the car's settings ``vehicle`` lack."""
        return tuple(k for k in self.requires if getattr(vehicle, k, None) is None)

    def apply(self, structure: ModelStructure, values) -> ModelStructure:  # pragma: no cover - abstract
        """The structure with this effect's parameters ``values`` (physical units, in ``parameters``
        order) set in its fields."""
        raise NotImplementedError

    def prior_start(self, vehicle: Vehicle | None = None) -> tuple:
        """Start values of the parameters for a car's settings ``vehicle`` (default: ``start``)."""
        return self.start

    def augment(self, structure: ModelStructure, values) -> ModelStructure:
        """``apply`` plus the provenance entry (name and parameter values)."""
        values = np.asarray(values, float)
        if values.shape != (len(self.parameters),):
            raise ValueError(f"effect '{self.name}' takes {len(self.parameters)} parameter(s) {self.parameters}; got {values.shape}")
        out = self.apply(structure, values)
        record = (self.name, tuple((p, float(v)) for p, v in zip(self.parameters, values)))
        return replace(out, effects=structure.effects + (record,))

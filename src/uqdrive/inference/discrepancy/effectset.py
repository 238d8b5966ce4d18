"""Several registered effects fitted as one: the model of a verdict that names more than one
missing effect, and what the data can resolve of an effect's size.
"""

from __future__ import annotations

from typing import Mapping, Sequence

import numpy as np

from ...vehicle.augmented import actual_steering, reconstruction_error
from ...vehicle.effects import EFFECTS, FAMILIES, PHYSICAL, ModelStructure, SensorBias, SensorScale, acts_on

__all__ = ["EffectSet", "family_of", "fitted_values", "resolvable", "testable"]


def testable(candidates: Sequence[str], channels: Sequence[str]) -> tuple[list[str], list[dict]]:
    """The candidates that data with ``channels`` can test, and {"effect", "reason"} for the others.

    An effect acting only on channels that are not measured changes nothing that the data show
    (``lateral_kinematics`` without y); a sensor error of an unrecorded channel is no question at
    all and is dropped without a reason. A changing speed leaves every candidate testable (the
    chassis models follow it, the longitudinal load transfer from the force that follows it).
    """
    keep, untestable = [], []
    for name in candidates:
        e = EFFECTS[name]
        on = acts_on(name)
        if on is not None and not set(on) & set(channels):
            if not isinstance(e, (SensorBias, SensorScale)):
                untestable.append({"effect": family_of(name), "registry_name": name,
                                   "reason": f"without {' or '.join(on)}, {name} cannot be tested (it acts on {', '.join(on)} only)"})
            continue
        keep.append(name)
    return keep, untestable


def family_of(name: str) -> str:
    """Verdict name of a registry entry: ``sensor_bias_y`` -> ``sensor_bias``."""
    return next((fam for fam, members in FAMILIES.items() if name in members), name)


def fitted_values(fit) -> dict[str, list[float]]:
    """{effect: its fitted parameter values} of a fit whose ``effect`` is an :class:`EffectSet`
    (the start of a refit with these effects, or with some of them)."""
    return {k: list(v) for k, v in fit.effect.split(fit.effect_values_).items()}


class EffectSet:
    """Registered effects applied one after the other, with their parameters concatenated.

    It has the interface of :class:`uqdrive.vehicle.effects.Effect` that
    :class:`.fit.StructureFit` uses (``parameters``, ``bounds``, ``start``, ``augment``), so the
    distributions and every effect's parameters are fitted jointly. Parameter names are
    ``effect.parameter`` (two effects may share a parameter name).

    Parameters
    ----------
    names : sequence of str
        Registry names, in the order they were added.
    start : mapping of str to sequence of float, optional
        Start values per effect (default: the registry's).
    """

    def __init__(self, names: Sequence[str], start: Mapping[str, Sequence[float]] | None = None):
        self.names = tuple(names)
        if len(set(self.names)) != len(self.names):
            raise ValueError(f"an effect is added at most once; got {self.names}")
        self.members = tuple(EFFECTS[n] for n in self.names)
        self.name = "+".join(self.names)
        self.parameters = tuple(f"{n}.{p}" for n, e in zip(self.names, self.members) for p in e.parameters)
        self.units = tuple(u for e in self.members for u in e.units)
        self.bounds = tuple(b for e in self.members for b in e.bounds)
        start = dict(start or {})
        self.start = tuple(float(v) for n, e in zip(self.names, self.members) for v in start.get(n, e.start))
        if len(self.start) != len(self.parameters):
            raise ValueError(f"start values of {self.names} do not match their parameters {self.parameters}")

    def split(self, values) -> dict[str, np.ndarray]:
        """{effect: its parameter values} from the concatenated ``values``."""
        values = np.asarray(values, float)
        out, i = {}, 0
        for n, e in zip(self.names, self.members):
            out[n] = values[i:i + len(e.parameters)]
            i += len(e.parameters)
        return out

    def augment(self, structure: ModelStructure, values) -> ModelStructure:
        """``structure`` with every member applied (each adds its provenance record)."""
        values = np.asarray(values, float)
        if values.shape != (len(self.parameters),):
            raise ValueError(f"effects {self.names} take {len(self.parameters)} parameter(s); got {values.shape}")
        for n, v in self.split(values).items():
            structure = EFFECTS[n].augment(structure, v)
        return structure

    def physical(self, release: Sequence[str] = ()) -> dict[int, float]:
        """{index into ``parameters``: value} of the parameters held at their one physical value
        (:data:`uqdrive.vehicle.effects.PHYSICAL`), except those of the effects in ``release``."""
        return {self.parameters.index(f"{n}.{PHYSICAL[n][0]}"): PHYSICAL[n][1] for n in self.names if n in PHYSICAL and n not in release}

    def intervals(self, flat: Mapping[str, Sequence[float]]) -> dict[str, dict[str, list[float]]]:
        """{effect: {parameter: [estimate, lo95, hi95]}} from StructureFit.effect_intervals."""
        out: dict[str, dict[str, list[float]]] = {n: {} for n in self.names}
        for key, iv in flat.items():
            n, p = key.split(".", 1)
            out[n][p] = [float(v) for v in iv]
        return out


def resolvable(name: str, values, delta, dt: float) -> tuple[bool, str]:
    """Whether an effect of the fitted size can be told apart from the data's sampling.

    A dead time below one sample of the measured grid, or a steering lag that moves the input
    by less than the input's own reconstruction error (the linear and the held reconstruction
    differ by half a step change, :func:`uqdrive.vehicle.augmented.reconstruction_error`), is
    a property of how the samples are read, not physics.

    Parameters
    ----------
    name : str
        Registry name.
    values : sequence of float
        The effect's fitted parameters.
    delta : ndarray, shape (T,)
        Commanded steering (rad) on the measured grid.
    dt : float
        Measured grid step (s).

    Returns
    -------
    ok : bool
    reason : str
        Why not (empty when resolvable).
    """
    v = float(np.asarray(values, float)[0]) if len(values) else 0.0
    if name == "actuator_delay" and v < dt:
        return False, f"delay {v * 1e3:.2g} ms below one sample ({dt * 1e3:.3g} ms)"
    if name == "actuator_lag":
        # from the first step on: at t = 0 any lag holds the wheel at 0 whatever its size
        moved = float(np.sqrt(np.mean((actual_steering(delta, dt, lag=max(v, 0.0)) - np.asarray(delta, float))[1:] ** 2)))
        floor = reconstruction_error(delta, dt)
        if moved <= floor:
            return False, f"lag {v * 1e3:.2g} ms moves the input by {moved:.2g} rad RMS, within its reconstruction error {floor:.2g} rad"
    return True, ""

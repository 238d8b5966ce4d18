"""Named physical effects that the thesis' single-track models leave out, as a registry: each a small
class with 1-3 parameters whose ``apply`` returns the :class:`ModelStructure` that
:mod:`uqdrive.vehicle.augmented` simulates (an effect simulates nothing itself).
"""

from __future__ import annotations

from dataclasses import replace
from typing import Mapping

import numpy as np

from .sensors import SENSOR_CHANNELS, SensorBias, SensorScale, channel_effects
from .structure import Effect, ModelStructure
from .tyre import LoadSensitiveTyre, TyreShape, shape_parts, with_tyre_shape

__all__ = ["ModelStructure", "Effect", "EFFECTS", "FAMILIES", "VANISHES", "PHYSICAL", "effect", "expand_names", "channel_effects", "structure_from_effects", "acts_on", "SENSOR_CHANNELS",
           "SensorBias", "SensorScale", "LoadSensitiveTyre", "TyreShape", "with_tyre_shape", "shape_parts"]


class TyreSaturation(Effect):
    """Non-linear tyre: the Magic Formula (2.2) with curvature factor E (-) replaces the linear tyre."""

    def apply(self, s, v):
        return replace(s, tyre="magic_formula", tyre_curvature=float(v[0]))


class ActuatorLag(Effect):
    """First-order lag with time constant T (s) between commanded and actual steering angle."""

    vanishes = ("T", 0.0)

    def apply(self, s, v):
        return replace(s, steering_lag=float(v[0]))


class ActuatorDelay(Effect):
    """Dead time tau (s) between commanded and actual steering angle."""

    vanishes = ("tau", 0.0)

    def apply(self, s, v):
        return replace(s, steering_delay=float(v[0]))


class RoadBank(Effect):
    """Road bank angle phi (deg): a constant lateral acceleration g sin(phi) without yaw moment."""

    vanishes = ("phi", 0.0)

    def apply(self, s, v):
        return replace(s, lateral_acceleration=9.81 * float(np.sin(np.deg2rad(v[0]))))


class WindGust(Effect):
    """Time-variant side wind scaled by gust_scale (-) against the configured F_w,sigma."""

    vanishes = ("gust_scale", 1.0)

    def apply(self, s, v):
        return replace(s, gust_scale=float(v[0]))


class LateralKinematics(Effect):
    """Lateral velocity along the course angle: weight k (-) of beta in y_dot = v (psi + k beta)."""

    vanishes = ("k", 0.0)
    physical = ("k", 1.0)

    def apply(self, s, v):
        return replace(s, course_weight=float(v[0]), course_exact=True)


class LongitudinalLoadTransfer(Effect):
    """Axle loads shifted by the longitudinal acceleration at centre-of-gravity height h (m):
    F_zf = m (g l_r - a_x h) / L, the tyre peaks following the loads."""

    vanishes = ("h", 0.0)

    def apply(self, s, v):
        return replace(s, pitch_height=float(v[0]))

    def prior_start(self, vehicle=None):
        """The car's ``cg_height`` where given."""
        return self.start if getattr(vehicle, "cg_height", None) is None else (float(vehicle.cg_height),)


class LateralLoadTransfer(Effect):
    """Lateral load transfer split by the front roll-stiffness share chi_f (-), with the tyre
    load sensitivity p_Dz (-) lowering the peak of the more loaded wheel."""

    vanishes = ("p_Dz", 0.0)

    def apply(self, s, v):
        return replace(s, roll_share_front=float(v[0]), load_sensitivity=float(v[1]))


class ComplianceSteer(Effect):
    """Road-wheel angle change per g of the front axle's force over its static load, K (deg/g):
    the steering's compliance (at steady cornering K per g of lateral acceleration, as roll steer)."""

    vanishes = ("K", 0.0)

    def apply(self, s, v):
        return replace(s, compliance_steer=float(v[0]))


class RollSteer(Effect):
    """Roll steer: the front wheels turn by -K (deg/g) per g of the tyres' lateral force over the
    base mass, through the body's roll, a second-order mode of frequency f (Hz) and damping ratio zeta."""

    vanishes = ("K", 0.0)

    def apply(self, s, v):
        return replace(s, roll_steer=float(v[0]), roll_frequency=float(v[1]), roll_damping=float(v[2]))


class TyreRelaxation(Effect):
    """Tyre relaxation: the slip angles follow their steady values with the lag sigma / v of the
    relaxation length sigma (m)."""

    vanishes = ("sigma", 0.0)

    def apply(self, s, v):
        return replace(s, relaxation_length=float(v[0]))


class CombinedSlip(Effect):
    """Friction ellipse per axle, F_y = F_y0 sqrt(1 - (kappa F_x,i / (mu F_z,i))^2), F_x = m a_x split by drive layout chi_d."""

    vanishes = ("kappa", 0.0)

    def apply(self, s, v):
        return replace(s, combined_slip=float(v[0]), drive_share_front=float(v[1]))


#: Registry of candidate effects; config strings and ``--candidates`` select them. A family name
#: (``sensor_bias``, ``sensor_scale``) stands for its four per-channel members.
EFFECTS: dict[str, Effect] = {
    "tyre_saturation": TyreSaturation(
        "tyre_saturation", ("E",), ("-",), ((-2.0, 1.0),), (0.5,),
        "non-linear tyre force: Magic Formula (2.2) with D = mu instead of the linear c alpha",
        "peaks of psi_dot and beta flattened where the lateral acceleration is high; std grows with the excitation"),
    "actuator_lag": ActuatorLag(
        "actuator_lag", ("T",), ("s",), ((0.0, 1.0),), (0.05,),
        "first-order lag between commanded and actual steering angle",
        "every channel's mean delayed and attenuated, more at higher input frequencies"),
    "actuator_delay": ActuatorDelay(
        "actuator_delay", ("tau",), ("s",), ((0.0, 0.5),), (0.05,),
        "dead time between commanded and actual steering angle",
        "every channel's mean shifted in time by the same amount, amplitude kept"),
    "road_bank": RoadBank(
        "road_bank", ("phi",), ("deg",), ((-10.0, 10.0),), (0.0,),
        "road inclination: constant lateral force m g sin(phi) without yaw moment",
        "a drift of y's mean growing with time and a constant offset of beta, std unchanged"),
    "wind_gust": WindGust(
        "wind_gust", ("gust_scale",), ("-",), ((0.0, 20.0),), (1.5,),
        "time-variant side wind stronger than F_w,sigma assumes",
        "std of every channel grows (y most), means unchanged"),
    "lateral_kinematics": LateralKinematics(
        "lateral_kinematics", ("k",), ("-",), ((-0.5, 2.0),), (0.5,),
        "lateral velocity along the course angle, y_dot = v sin(psi + beta), not the heading alone",
        "y only: its mean follows v sin(psi + k beta), psi, psi_dot, beta untouched"),
    **channel_effects("sensor_bias"),
    **channel_effects("sensor_scale"),
    "longitudinal_load_transfer": LongitudinalLoadTransfer(
        "longitudinal_load_transfer", ("h",), ("m",), ((0.0, 1.5),), (0.55,),
        "load moved between the axles by the longitudinal force that holds the speed in a turn: "
        "F_zf = m (g l_r - a_x h) / L with a_x = -tan(beta) a_y (and v' cos(beta) along a speed profile); "
        "h the centre-of-gravity height",
        "grows with psi_dot * beta: the yaw-rate gain and beta change where the side slip is large, "
        "nothing in straight driving; stronger with a saturating tyre", requires=("cg_height",)),
    "lateral_load_transfer": LateralLoadTransfer(
        "lateral_load_transfer", ("chi_f", "p_Dz"), ("-", "-"), ((0.0, 1.0), (-1.0, 0.0)), (0.55, -0.1),
        "load moved from the inner to the outer wheels by the roll moment of the tyres' lateral force T, h T / t "
        "split chi_f : 1 - chi_f front : rear, "
        "with a load-sensitive tyre peak mu F_z (1 + p_Dz dfz): the axle's force falls by p_Dz (dF / F_z0)^2",
        "psi_dot and beta peaks change quadratically in the lateral acceleration (none at small a_y); "
        "chi_f > l_r / L adds understeer", requires=("cg_height", "track_width")),
    "compliance_steer": ComplianceSteer(
        "compliance_steer", ("K",), ("deg/g",), ((-1.0, 3.0),), (0.3,),
        "front wheels yield to their lateral force: -K per g of F_f / F_zf,static (at steady cornering -K a_y / g, "
        "roll steer's unit); on the linear tyre a front cornering stiffness c_f / (1 + K c_Sf C mu)",
        "yaw-rate gain changed by the same fraction at every amplitude (an understeer-gradient shift), "
        "beta with it; phase untouched at low frequency"),
    "roll_steer": RollSteer(
        "roll_steer", ("K", "f", "zeta"), ("deg/g", "Hz", "-"), ((-1.0, 3.0), (0.5, 6.0), (0.1, 1.5)), (0.3, 2.0, 0.6),
        "front wheels steered by the body's roll: -K per g of the tyres' lateral force over the base mass at steady "
        "cornering, the roll a second-order mode (frequency f, damping ratio zeta) driven by that force",
        "yaw-rate gain changed by the same fraction at every amplitude (an understeer-gradient shift); "
        "the steer lags a_y by the roll mode: yaw overshoot and a later peak after a sharp input"),
    "tyre_relaxation": TyreRelaxation(
        "tyre_relaxation", ("sigma",), ("m",), ((0.05, 2.0),), (0.5,),
        "slip angles lag their steady values by the tyre's relaxation length: time constant sigma / v",
        "every channel's response delayed and its yaw-rate peak raised at high input frequencies; "
        "steady states untouched"),
    "combined_slip": CombinedSlip(
        "combined_slip", ("kappa", "chi_d"), ("-", "-"), ((0.0, 3.0), (0.0, 1.0)), (1.0, 0.5),
        "the longitudinal force F_x = m a_x that follows the speed (a_x = v' cos(beta) - tan(beta) (a_y - v' sin(beta))) takes lateral "
        "capacity by the friction ellipse: an axle keeps sqrt(1 - (kappa F_x,i / (mu F_z,i))^2); drive split chi_d front, brakes by static loads",
        "none at held speed straight ahead; braking or driving in a turn: rear-axle force raises yaw rate and beta, front lowers them"),
    "load_sensitive_tyre": LoadSensitiveTyre(
        "load_sensitive_tyre", ("q", "p_Dz"), ("-", "-"), ((-1.0, 1.0), (-1.0, 0.5)), (-0.3, -0.1),
        "cornering stiffness and peak not proportional to the axle load: K_y,i = mu F_z,i B C (1 + q dfz_i), "
        "D_i = mu F_z,i (1 + p_Dz dfz_i), dfz_i = F_z,i / F_z0,i - 1 the axle load (the realisation's static load moved by the "
        "longitudinal acceleration at the car's cg_height) against the nominal car's",
        "the spread of the yaw-rate gain over the runs shrinks (q < 0: a more loaded axle gains less than its load); "
        "braking in a turn adds understeer, driving oversteer; with p_Dz the saturated forces too", requires=("cg_height",)),
    "tyre_shape": TyreShape(
        "tyre_shape", ("b", "C", "E"), ("-", "-", "-"), ((0.3, 3.0), (1.0, 2.5), (-2.0, 1.0)), (1.0, 1.6, 0.5),
        "the tyre's own Magic-Formula shape instead of the car's: F_i = mu F_z,i sin(C atan(b B_i alpha - E (b B_i alpha - atan(b B_i alpha)))), "
        "b the factor on the car's B_f and B_r, C and E fitted with the distributions",
        "like tyre_saturation, with the slope at small slip (b C) and the fall past the peak (C) the data's own: "
        "peaks of psi_dot and beta flattened where the lateral acceleration is high, the spread over mu changed with them"),
}

#: Where each effect vanishes, (parameter, value), read from the registry (:attr:`Effect.vanishes`):
#: a named effect must have a size the data tell from it. Effects without one (the Magic Formula's
#: curvature E) are not listed.
VANISHES: dict[str, tuple[str, float]] = {n: e.vanishes for n, e in EFFECTS.items() if e.vanishes is not None}

#: The one value a parameter has by its physics, (parameter, value), from the registry
#: (:attr:`Effect.physical`): discovery judges the effect there and reports a free fit's departure
#: beside it (the rest of the gap acting through it).
PHYSICAL: dict[str, tuple[str, float]] = {n: e.physical for n, e in EFFECTS.items() if e.physical is not None}

#: Families that name several registry entries at once.
FAMILIES = {"sensor_bias": tuple(f"sensor_bias_{c}" for c in SENSOR_CHANNELS), "sensor_scale": tuple(f"sensor_scale_{c}" for c in SENSOR_CHANNELS)}


def acts_on(name: str) -> tuple | None:
    """The measured channels an effect alone acts on, or None when it changes the dynamics (every
    channel): a sensor effect its channel, ``lateral_kinematics`` y (the course kinematics)."""
    e = effect(name)
    if isinstance(e, (SensorBias, SensorScale)):
        return (e.channel,)
    if isinstance(e, LateralKinematics):
        return ("y",)
    return None


def effect(name: str) -> Effect:
    """The registered effect ``name``; a clear error naming the known ones otherwise."""
    try:
        return EFFECTS[name]
    except KeyError:
        raise KeyError(f"unknown effect '{name}'; known effects: {', '.join(sorted(set(EFFECTS) | set(FAMILIES) | {'all'}))}") from None


def expand_names(names) -> list[str]:
    """Registry names of ``names`` (``"all"``: every effect), families expanded (order kept, duplicates dropped)."""
    out: list[str] = []
    for n in [names] if isinstance(names, str) else names:
        for m in EFFECTS if n == "all" else FAMILIES.get(n, (n,)):
            effect(m)
            if m not in out:
                out.append(m)
    return out


def structure_from_effects(records: Mapping[str, Mapping[str, float]] | None) -> ModelStructure:
    """The :class:`ModelStructure` of the baseline plus ``{effect: {parameter: value}}``."""
    s = ModelStructure()
    for name, params in (records or {}).items():
        e = effect(name)
        missing = [p for p in e.parameters if p not in params]
        if missing:
            raise ValueError(f"effect '{name}' needs parameter(s) {missing}")
        s = e.augment(s, [params[p] for p in e.parameters])
    return s

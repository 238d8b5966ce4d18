"""Typed settings parsed once from a validated config, a vehicle file and the data's own facts:
the frozen objects every model and algorithm below the command line, studies and scripts reads.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from types import MappingProxyType
from typing import Any, Mapping

from ..config import config_hash, restrict_config
from .car import PARAMETER_NAMES, Normal, ParameterLayout, Uncertainty, Uniform, Vehicle
from .run import Control, Discover, Identify, SpeedRamp, Spin, Steering, TimeGrid, WheelSlipCar, Wind

__all__ = [
    "PARAMETER_NAMES",
    "Vehicle",
    "Normal",
    "Uniform",
    "Uncertainty",
    "TimeGrid",
    "SpeedRamp",
    "Wind",
    "Steering",
    "Spin",
    "Identify",
    "Discover",
    "ParameterLayout",
    "Control",
    "WheelSlipCar",
    "Settings",
    "ENSEMBLE_SETTINGS",
    "ensemble_hash",
]

#: The settings an ensemble depends on besides its size and seed (the keys an ensemble reads).
ENSEMBLE_SETTINGS = ("vehicle", "tyre", "uncertainty", "wind", "steering", "time", "montecarlo.spin_threshold")


def _ensemble_keys(config: Mapping[str, Any]) -> tuple:
    return ENSEMBLE_SETTINGS + (("montecarlo.speed_profile",) if config.get("montecarlo", {}).get("speed_profile") else ())


def _hash(settings: Mapping[str, Any], samples: int, seed: int, chunk: int | None) -> str:
    out = {"settings": settings, "samples": int(samples), "seed": int(seed)}
    if chunk is not None:
        out["chunk"] = int(chunk)
    return config_hash(out)


def ensemble_hash(config: Mapping[str, Any], samples: int, seed: int, chunk: int | None = None) -> str:
    """:func:`uqdrive.config.config_hash` of what an ensemble depends on: the settings it reads
    and its effective size, seed and chunk (an override of ``samples`` or ``seed`` counts), so the
    CLI and the workflow write the same hash for the same ensemble, whatever else their configs hold."""
    return _hash(restrict_config(config, _ensemble_keys(config)), samples, seed, chunk)


def _provenance(config: Mapping[str, Any], time: TimeGrid | None, speed_kmh: float | None):
    """What an ensemble reads of ``config``, with the data's facts that replace parts of it
    (read-only), or None when ``config`` lacks a part of it."""
    try:
        out = restrict_config(config, _ensemble_keys(config))
    except KeyError:
        return None
    if time is not None:
        out["time"] = {"t_end": time.t_end, "dt": time.dt, "step": time.step}
    if speed_kmh is not None:
        out["vehicle"]["speed_kmh"] = speed_kmh
    return MappingProxyType(out)


@dataclass(frozen=True)
class Settings:
    """Everything a model or algorithm reads, parsed once from a validated config.

    Build it where a command, a workflow script or a study starts (:meth:`from_config`) and
    pass it, or the part of it needed, down; nothing below those edges reads the config mapping.
    A part (or a field) whose keys the config lacks is None: each workflow rule hands its script
    the config restricted to the keys it reads, and the models read only their own fields.
    """

    seed: int | None = None
    vehicle: Vehicle | None = None
    uncertainty: Uncertainty | None = None
    time: TimeGrid | None = None
    wind: Wind | None = None
    steering: Steering | None = None
    spin: Spin | None = None
    speed: SpeedRamp | None = None
    noise_levels: tuple = ()
    identify: Identify = field(default_factory=Identify)
    discover: Discover = field(default_factory=Discover)
    samples: int | None = None
    bayes_prior: tuple = ()
    control: Control | None = None
    wheelslip: WheelSlipCar | None = None
    ensemble_provenance: Mapping[str, Any] | None = field(default=None, repr=False, compare=False)

    @classmethod
    def from_config(cls, config: Mapping[str, Any], *, time: TimeGrid | None = None, speed: float | None = None,
                    seed: int | None = None) -> "Settings":
        """The settings of a validated config, with the data's facts where given.

        Parameters
        ----------
        config : mapping
            A validated (and vehicle-normalised) config, :func:`uqdrive.config.load_config`, or
            a part of one (:func:`uqdrive.config.restrict_config`).
        time : TimeGrid, optional
            The data's grid, replacing the config's ``time`` section.
        speed : float, optional
            The data's constant speed (m/s), replacing ``vehicle.speed_kmh``.
        seed : int, optional
            Replaces the config's root ``seed``.
        """
        unc = config.get("uncertainty", {})
        veh = None
        if "vehicle" in config:
            veh = Vehicle.from_sections(config["vehicle"], config.get("tyre", {}), unc.get("l_f", {}).get("mean"))
            if speed is not None:
                veh = veh.at_speed(float(speed))
        t, w, st, mc = (config.get(k) for k in ("time", "wind", "steering", "montecarlo"))
        mc = mc or {}
        ramp = mc.get("speed_profile")
        ident = config.get("identification", {})
        prior = config.get("bayes", {}).get("prior", {})
        c, ws = config.get("control"), config.get("wheelslip")
        seed = config.get("seed") if seed is None else seed
        return cls(
            seed=None if seed is None else int(seed),
            vehicle=veh,
            uncertainty=Uncertainty.from_section(unc) if unc else None,
            time=time if time is not None else None if t is None else TimeGrid(t.get("t_end"), t.get("dt"), t.get("step")),
            wind=None if w is None else Wind(w.get("sigma"), w.get("Tc"), w.get("kle_quadrature"), w.get("kle_truncation"),
                                             bool(w.get("gust_yaw_moment", True))),
            steering=None if st is None else Steering(st.get("delta_max_deg"), st.get("period")),
            spin=Spin(mc.get("spin_threshold"), mc.get("spin_policy", "exclude")),
            speed=SpeedRamp(ramp["start_kmh"], ramp["end_kmh"], ramp["duration"], ramp.get("t_start", 0.0)) if ramp else None,
            noise_levels=tuple(config.get("noise", {}).get("levels", ())),
            identify=Identify(**{k: ident[k] for k in Identify.__dataclass_fields__ if k in ident}),
            discover=Discover.from_section(config.get("discrepancy", {})),
            samples=int(mc["samples"]) if "samples" in mc else None,
            bayes_prior=tuple(tuple(prior[n]) for n in ParameterLayout.names) if all(n in prior for n in ParameterLayout.names) else (),
            control=None if c is None else Control(**{k: tuple(c[k]) if isinstance(c[k], list) else c[k]
                                                      for k in Control.__dataclass_fields__ if k in c}),
            wheelslip=None if ws is None else WheelSlipCar(**{k: ws[k] for k in WheelSlipCar.__dataclass_fields__ if k in ws}),
            ensemble_provenance=_provenance(config, time, veh.speed_kmh if speed is not None else None),
        )

    def ensemble_hash(self, samples: int, seed: int, chunk: int | None = None) -> str:
        """:func:`ensemble_hash` of the config these settings were parsed from."""
        if self.ensemble_provenance is None:
            raise KeyError(f"the config lacks a key an ensemble reads ({', '.join(ENSEMBLE_SETTINGS)})")
        return _hash(dict(self.ensemble_provenance), samples, seed, chunk)

    @property
    def layout(self) -> ParameterLayout:
        """The distribution parameters' layout of this uncertainty."""
        return ParameterLayout.of(self.uncertainty)

    def with_time(self, time: TimeGrid) -> "Settings":
        """The same settings on another time grid."""
        return replace(self, time=time)

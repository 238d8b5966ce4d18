"""The car and its uncertain quantities as typed settings: the model's constants of one vehicle,
the distributions of (5.8)-(5.11) and the layout of their parameters."""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from types import MappingProxyType
from typing import Any, Mapping

import numpy as np

from ..config import ConfigError
from ..vehicle_spec import ENGINEERING_KEYS, OPTIONAL_QUANTITIES, internal_constants

__all__ = ["PARAMETER_NAMES", "IDENTIFY_BOX", "metres_per_second", "Vehicle", "Normal", "Uniform", "Uncertainty", "ParameterLayout"]


#: Stationary uncertainties in germ order xi_1..xi_4 of (5.8)-(5.11).
PARAMETER_NAMES = ("mu", "m_load", "l_f", "F_w_mean")


def metres_per_second(kmh):
    """A speed in km/h (float or ndarray, any shape) in m/s: kmh / 3.6."""
    return kmh / 3.6


@dataclass(frozen=True)
class Vehicle:
    """The single-track model's constants of one car, in the model's internal terms.

    Attributes
    ----------
    m_base, J0, wheelbase, c_Sf, c_Sr, M_c, g, C, E : float
        Base mass (kg), specific yaw inertia I_z / m (m^2), wheelbase L (m), front and rear
        Magic-Formula stiffness factors B (-), yaw moment per unit side force (m), gravity
        (m/s^2), Magic-Formula shape and curvature factors (-).
    speed_kmh, v_c : float
        The constant speed in km/h and in m/s.
    cg_height, track_width, steering_ratio : float or None
        The optional quantities (m, m, -) of :data:`uqdrive.vehicle_spec.OPTIONAL_QUANTITIES`.
    """

    m_base: float
    J0: float
    wheelbase: float
    c_Sf: float
    c_Sr: float
    M_c: float
    g: float
    C: float
    E: float
    speed_kmh: float
    v_c: float
    cg_height: float | None = None
    track_width: float | None = None
    steering_ratio: float | None = None

    @classmethod
    def from_sections(cls, vehicle: Mapping[str, Any], tyre: Mapping[str, Any], l_f: float | None = None) -> "Vehicle":
        """The model's constants of a vehicle section in either form (engineering units or internal).

        The engineering forms are converted by :func:`uqdrive.vehicle_spec.internal_constants`::

            m_base = mass,    J0 = I_z / m_base,    l_f = cg_to_front_axle  or  L (1 - share)
            B_f = C_alpha,f / (F_zf,nom C),  F_zf,nom = m_base g l_r / L     (2.2a) slope, mu = 1
            B_r = C_alpha,r / (F_zr,nom C),  F_zr,nom = m_base g l_f / L,    l_r = L - l_f

        and the speed, given in km/h, once here::

            v_c = speed_kmh / 3.6     (m/s)

        A quantity the sections lack (a workflow rule's restricted config) is None.
        """
        if any(key in vehicle for key in ENGINEERING_KEYS):
            k = internal_constants(vehicle, tyre, l_f)
        else:
            k = {**{key: vehicle.get(key) for key in ("m_base", "J0", "wheelbase", "c_Sf", "c_Sr")}, "C": tyre.get("C"), "E": tyre.get("E")}
        kmh = vehicle.get("speed_kmh")
        return cls(m_base=k["m_base"], J0=k["J0"], wheelbase=k["wheelbase"], c_Sf=k["c_Sf"], c_Sr=k["c_Sr"], M_c=vehicle.get("M_c"),
                   g=vehicle.get("g"), C=k["C"], E=k["E"], speed_kmh=kmh, v_c=None if kmh is None else metres_per_second(kmh),
                   **{q: vehicle.get(q) for q in OPTIONAL_QUANTITIES})

    def at_speed(self, v: float) -> "Vehicle":
        """The same car at the constant speed ``v`` (m/s), taken through km/h as a config's speed is."""
        kmh = v * 3.6
        return replace(self, speed_kmh=kmh, v_c=metres_per_second(kmh))

    def require(self, key: str, purpose: str) -> float:
        """The optional quantity ``key`` (:data:`uqdrive.vehicle_spec.OPTIONAL_QUANTITIES`), or a
        :class:`ConfigError` naming it and ``purpose`` (what needs it)."""
        unit, meaning = OPTIONAL_QUANTITIES[key]
        value = getattr(self, key)
        if value is None:
            raise ConfigError(f"{purpose} needs config key 'vehicle.{key}' ({meaning}, {unit}), which is not given; "
                              f"add it to the vehicle section or the vehicle file")
        return float(value)


@dataclass(frozen=True)
class Normal:
    """A normal quantity N(mean, std^2); ``std == 0`` declares it known."""

    mean: float
    std: float

    def __post_init__(self):
        if self.std is not None and not self.std >= 0:
            raise ConfigError(f"a standard deviation of {self.std} is not a spread: give a std >= 0 (0: the quantity is known)")

    @property
    def known(self) -> float | None:
        """Its value when known, else None."""
        return float(self.mean) if self.std == 0 else None

    @property
    def nominal(self) -> float:
        """The value a model without its germ uses: the mean."""
        return self.mean

    @property
    def theta(self) -> tuple[float, float]:
        """(mean, std)."""
        return (self.mean, self.std)


@dataclass(frozen=True)
class Uniform:
    """A uniform quantity U(low, high); ``low == high`` declares it known."""

    low: float
    high: float

    def __post_init__(self):
        if self.low is not None and self.high is not None and not self.low <= self.high:
            raise ConfigError(f"the interval [{self.low}, {self.high}] is reversed: give low <= high (equal: the quantity is known)")

    @property
    def known(self) -> float | None:
        """Its value when known, else None."""
        return float(self.low) if self.low == self.high else None

    @property
    def nominal(self) -> float:
        """The value a model without its germ uses: the midpoint."""
        return 0.5 * (self.low + self.high)

    @property
    def theta(self) -> tuple[float, float]:
        """(low, high)."""
        return (self.low, self.high)


@dataclass(frozen=True)
class Uncertainty:
    """The uncertain quantities of (5.8)-(5.11): mu (-), m_load (kg), l_f (m) normal, the mean wind (N) uniform."""

    mu: Normal
    m_load: Normal
    l_f: Normal
    F_w_mean: Uniform

    @classmethod
    def from_section(cls, u: Mapping[str, Any]) -> "Uncertainty":
        """The quantities of a config's ``uncertainty`` section (one the section lacks is None, a
        value it lacks None)."""
        normal = [Normal(u[n].get("mean"), u[n].get("std")) if n in u else None for n in PARAMETER_NAMES[:3]]
        wind = u.get("F_w_mean")
        return cls(*normal, None if wind is None else Uniform(wind.get("low"), wind.get("high")))

    def known(self) -> dict[str, float]:
        """The quantities declared known, name -> value, in germ order."""
        out = {n: getattr(self, n).known for n in PARAMETER_NAMES if getattr(self, n) is not None}
        return {n: v for n, v in out.items() if v is not None}

    def nominal(self) -> dict[str, float]:
        """The means and the mean wind's midpoint, name -> value."""
        return {n: getattr(self, n).nominal for n in PARAMETER_NAMES}

    def theta(self, uncertain=PARAMETER_NAMES) -> np.ndarray:
        """The distribution parameters of ``uncertain`` in order, the known quantities left out."""
        known = self.known()
        return np.array([v for n in uncertain if n not in known for v in getattr(self, n).theta], float)


#: The identification's box per distribution parameter (identify's PCE model may also fit the
#: load): mu > 0, 0 < l_f < L (the wheelbase closes it), std > 0, mean wind within +- 5 kN.
IDENTIFY_BOX = {"mu_mean": (0.05, 3.0), "mu_std": (1e-4, 1.5), "l_f_mean": (0.05, None), "l_f_std": (1e-4, 1.5),
                "m_load_mean": (-500.0, 2000.0), "m_load_std": (1e-2, 500.0), "F_w_mean_low": (-5000.0, 5000.0),
                "F_w_mean_high": (-5000.0, 5000.0)}


@dataclass(frozen=True)
class ParameterLayout:
    """The six distribution parameters theta of the augmented model and of the identification
    with every quantity uncertain: names, the prior's values, which are known (index -> value),
    the discrepancy search's box and typical magnitudes (so an optimiser steps every parameter
    alike), and the identification's box (:meth:`identify_box`; the two boxes differ)."""

    names: tuple = ("mu_mean", "mu_std", "l_f_mean", "l_f_std", "F_w_mean_low", "F_w_mean_high")
    start: tuple = ()
    known: Mapping[int, float] = field(default_factory=lambda: MappingProxyType({}))
    bounds: tuple = ((0.1, 3.0), (0.0, 1.0), (0.3, 2.5), (0.0, 1.0), (-3000.0, 3000.0), (-3000.0, 3000.0))
    scales: tuple = (1.0, 0.2, 1.5, 0.2, 400.0, 400.0)

    @staticmethod
    def identify_box(theta_names, wheelbase: float) -> list:
        """The identification's (low, high) per name of ``theta_names`` (:data:`IDENTIFY_BOX`),
        the l_f mean's upper end 0.05 m short of the ``wheelbase`` (m)."""
        return [(lo, wheelbase - 0.05) if hi is None else (lo, hi) for lo, hi in (IDENTIFY_BOX[n] for n in theta_names)]

    @classmethod
    def of(cls, u: Uncertainty) -> "ParameterLayout":
        """The layout of the uncertainty ``u``: a known mu or l_f holds its mean and a std of 0,
        a known mean wind both bounds."""
        where = {"mu": (0, 1), "l_f": (2, 3), "F_w_mean": (4, 5)}
        known = {}
        for name, value in u.known().items():
            if name in where:
                i, j = where[name]
                known.update({i: value, j: value if name == "F_w_mean" else 0.0})
        start = (*u.mu.theta, *u.l_f.theta, *u.F_w_mean.theta)
        return cls(start=start, known=MappingProxyType(known))

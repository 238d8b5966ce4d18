"""Typed settings parsed once from a validated config, a vehicle file and the data's own facts:
the frozen objects every model and algorithm below the command line, studies and scripts reads.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from types import MappingProxyType
from typing import Any, Mapping

import numpy as np

from .config import ConfigError, config_hash, restrict_config
from .vehicle_spec import OPTIONAL_QUANTITIES, internal_constants

__all__ = [
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

#: Stationary uncertainties in germ order xi_1..xi_4 of (5.8)-(5.11).
PARAMETER_NAMES = ("mu", "m_load", "l_f", "F_w_mean")


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
        """
        k = internal_constants(vehicle, tyre, l_f)
        kmh = vehicle["speed_kmh"]
        return cls(m_base=k["m_base"], J0=k["J0"], wheelbase=k["wheelbase"], c_Sf=k["c_Sf"], c_Sr=k["c_Sr"], M_c=vehicle["M_c"],
                   g=vehicle["g"], C=k["C"], E=k["E"], speed_kmh=kmh, v_c=kmh / 3.6,
                   **{q: vehicle.get(q) for q in OPTIONAL_QUANTITIES})

    def at_speed(self, v: float) -> "Vehicle":
        """The same car at the constant speed ``v`` (m/s), taken through km/h as a config's speed is."""
        kmh = v * 3.6
        return replace(self, speed_kmh=kmh, v_c=kmh / 3.6)

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
        """The quantities of a config's ``uncertainty`` section."""
        return cls(*(Normal(u[n]["mean"], u[n]["std"]) for n in PARAMETER_NAMES[:3]), Uniform(u["F_w_mean"]["low"], u["F_w_mean"]["high"]))

    def known(self) -> dict[str, float]:
        """The quantities declared known, name -> value, in germ order."""
        out = {n: getattr(self, n).known for n in PARAMETER_NAMES}
        return {n: v for n, v in out.items() if v is not None}

    def nominal(self) -> dict[str, float]:
        """The means and the mean wind's midpoint, name -> value."""
        return {n: getattr(self, n).nominal for n in PARAMETER_NAMES}

    def theta(self, uncertain=PARAMETER_NAMES) -> np.ndarray:
        """The distribution parameters of ``uncertain`` in order, the known quantities left out."""
        known = self.known()
        return np.array([v for n in uncertain if n not in known for v in getattr(self, n).theta], float)


@dataclass(frozen=True)
class TimeGrid:
    """Output grid t_k = k dt on [0, t_end] and the fine integration step h = dt / substeps (s)."""

    t_end: float
    dt: float
    step: float

    @property
    def n_out(self) -> int:
        """Number of output intervals, t_end / dt."""
        return int(round(self.t_end / self.dt))

    @property
    def substeps(self) -> int:
        """Integration steps per output interval, dt / step."""
        return int(round(self.dt / self.step))

    @property
    def output(self) -> np.ndarray:
        """Output times, shape (n_out + 1,) (s)."""
        return np.arange(self.n_out + 1) * self.dt

    def fine(self, refine: int = 1) -> np.ndarray:
        """Fine grid with step h / refine (refine=2 gives the RK4 half-step grid)."""
        n = self.n_out * self.substeps * refine
        return np.arange(n + 1) * (self.step / refine)


@dataclass(frozen=True)
class SpeedRamp:
    """A linear speed change from ``start_kmh`` to ``end_kmh`` (km/h) over ``duration`` s from ``t_start`` s."""

    start_kmh: float
    end_kmh: float
    duration: float
    t_start: float = 0.0

    def on(self, t) -> np.ndarray:
        """v(t) (m/s) at the times ``t`` (s), same shape: constant before and after the change."""
        s = np.clip((np.asarray(t, float) - self.t_start) / self.duration, 0.0, 1.0)
        return (self.start_kmh + (self.end_kmh - self.start_kmh) * s) / 3.6


@dataclass(frozen=True)
class Wind:
    """The side wind (5.1)-(5.2) and its KLE settings (5.16)-(5.22): sigma (N), Tc (s), the
    Gauss-Legendre points and the truncation p_c, and whether the gusts exert the yaw moment M_c F_w."""

    sigma: float
    Tc: float
    kle_quadrature: int
    kle_truncation: float
    gust_yaw_moment: bool = True


@dataclass(frozen=True)
class Steering:
    """The sine steering (5.5)/(5.7): amplitude (deg) and period (s)."""

    delta_max_deg: float
    period: float

    @property
    def delta_max(self) -> float:
        """The amplitude in rad."""
        return np.deg2rad(self.delta_max_deg)


@dataclass(frozen=True)
class Spin:
    """A realisation with |beta| above ``threshold`` (rad) lost control; ``policy`` keep | exclude."""

    threshold: float
    policy: str = "exclude"


@dataclass(frozen=True)
class Identify:
    """The identification's settings (sec. 5.3.2): PCE order and Gauss points, iterations, state scales, optimiser."""

    order: int = 2
    quadrature_points: int = 4
    max_iter: int = 300
    state_scale: str = "none"
    normalised_state_scale: str = "rms_mean"
    optimiser: str = "lbfgsb"

    def scale(self, normalised: bool = False) -> str:
        """The state scale of the thesis-faithful fit, or of the normalised one."""
        return self.normalised_state_scale if normalised else self.state_scale


@dataclass(frozen=True)
class Discover:
    """The discrepancy search's settings (``discrepancy`` section): candidates, ensemble sizes,
    bootstrap, level, compared times, screened and added effects, and the posterior's settings."""

    candidates: tuple | None = None
    model_samples: int = 1000
    nonlinear_samples: int = 300
    bootstrap: int = 200
    level: float = 0.01
    max_times: int = 150
    top: int = 3
    max_effects: int = 3
    posterior_enabled: bool = False
    posterior_effects: tuple = ()
    posterior: Mapping[str, Any] = field(default_factory=lambda: MappingProxyType({}))

    @classmethod
    def from_section(cls, d: Mapping[str, Any]) -> "Discover":
        """The settings of a config's ``discrepancy`` section (missing keys take the defaults)."""
        p = dict(d.get("posterior", {}))
        fields = {k: d[k] for k in ("model_samples", "nonlinear_samples", "bootstrap", "level", "max_times", "top", "max_effects") if k in d}
        return cls(candidates=tuple(d["candidates"]) if "candidates" in d else None, **fields,
                   posterior_enabled=bool(p.get("enabled", False)), posterior_effects=tuple(p.get("effects") or ()),
                   posterior=MappingProxyType({k: v for k, v in p.items() if k not in ("enabled", "effects")}))

    def wants_posterior(self, effect: str) -> bool:
        """Whether the posterior of a verdict naming ``effect`` is sampled."""
        return self.posterior_enabled and (not self.posterior_effects or effect in self.posterior_effects)


@dataclass(frozen=True)
class ParameterLayout:
    """The six distribution parameters theta of the augmented model and of the identification
    with every quantity uncertain: names, the prior's values, and which are known (index -> value)."""

    names: tuple = ("mu_mean", "mu_std", "l_f_mean", "l_f_std", "F_w_mean_low", "F_w_mean_high")
    start: tuple = ()
    known: Mapping[int, float] = field(default_factory=lambda: MappingProxyType({}))

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


@dataclass(frozen=True)
class Control:
    """The lane-keeping controller's case (6.1), (5.35)-(5.38): initial offset range y0 (m), yaw
    psi0 (deg), horizon T (s), the mean/variance split gamma and the LQR weights."""

    y0: tuple = (0.0, 1.75)
    psi0_deg: float = 5.0
    horizon: float = 2.0
    gamma: float = 0.001
    Q_diag: tuple = (1.0, 1.0, 1.0, 10.0)
    R: float = 100.0


@dataclass(frozen=True)
class WheelSlipCar:
    """The quarter car of the wheel-slip controller (GP paper, sec. III): wheel radius r (m),
    load F_z (N), mass (kg), wheel inertia J (kg m^2), actuator time constant T_a (s), curve
    slope k, peak friction mu_H, slip set-point, damping and natural frequency (rad/s)."""

    r: float = 0.35
    F_z: float = 2452.5
    mass: float = 250.0
    J: float = 0.68
    T_a: float = 0.014
    k: float = 28.0
    mu_H: float = 0.9
    lambda_star: float = 0.15
    zeta_d: float = 0.5
    omega_0d: float = 20 * np.pi


#: The settings an ensemble depends on besides its size and seed (the keys an ensemble reads).
ENSEMBLE_SETTINGS = ("vehicle", "tyre", "uncertainty", "wind", "steering", "time", "montecarlo.spin_threshold")


def _ensemble_keys(config: Mapping[str, Any]) -> tuple:
    return ENSEMBLE_SETTINGS + (("montecarlo.speed_profile",) if config["montecarlo"].get("speed_profile") else ())


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


def _provenance(config: Mapping[str, Any], time: TimeGrid | None, speed_kmh: float | None) -> dict:
    """What an ensemble reads of ``config``, with the data's facts that replace parts of it."""
    out = restrict_config(config, _ensemble_keys(config))
    if time is not None:
        out["time"] = {"t_end": time.t_end, "dt": time.dt, "step": time.step}
    if speed_kmh is not None:
        out["vehicle"]["speed_kmh"] = speed_kmh
    return out


@dataclass(frozen=True)
class Settings:
    """Everything a model or algorithm reads, parsed once from a validated config.

    Build it where a command, a workflow script or a study starts (:meth:`from_config`) and
    pass it, or the part of it needed, down; nothing below those edges reads the config mapping.
    """

    seed: int
    vehicle: Vehicle
    uncertainty: Uncertainty
    time: TimeGrid
    wind: Wind
    steering: Steering
    spin: Spin
    speed: SpeedRamp | None = None
    noise_levels: tuple = ()
    identify: Identify = field(default_factory=Identify)
    discover: Discover = field(default_factory=Discover)
    samples: int = 2000
    bayes_prior: tuple = ()
    control: Control = field(default_factory=Control)
    wheelslip: WheelSlipCar = field(default_factory=WheelSlipCar)
    ensemble_provenance: Mapping[str, Any] = field(default_factory=lambda: MappingProxyType({}), repr=False, compare=False)

    @classmethod
    def from_config(cls, config: Mapping[str, Any], *, time: TimeGrid | None = None, speed: float | None = None,
                    seed: int | None = None) -> "Settings":
        """The settings of a validated config, with the data's facts where given.

        Parameters
        ----------
        config : mapping
            A validated (and vehicle-normalised) config, :func:`uqdrive.config.load_config`.
        time : TimeGrid, optional
            The data's grid, replacing the config's ``time`` section.
        speed : float, optional
            The data's constant speed (m/s), replacing ``vehicle.speed_kmh``.
        seed : int, optional
            Replaces the config's root ``seed``.
        """
        veh = Vehicle.from_sections(config["vehicle"], config["tyre"], config["uncertainty"]["l_f"].get("mean"))
        if speed is not None:
            veh = veh.at_speed(float(speed))
        t, w, st, mc = config["time"], config["wind"], config["steering"], config["montecarlo"]
        ramp = mc.get("speed_profile")
        ident = config.get("identification", {})
        prior = config.get("bayes", {}).get("prior")
        c, ws = config.get("control", {}), config.get("wheelslip", {})
        return cls(
            seed=int(config["seed"] if seed is None else seed),
            vehicle=veh,
            uncertainty=Uncertainty.from_section(config["uncertainty"]),
            time=TimeGrid(t["t_end"], t["dt"], t["step"]) if time is None else time,
            wind=Wind(w["sigma"], w["Tc"], w["kle_quadrature"], w["kle_truncation"], bool(w.get("gust_yaw_moment", True))),
            steering=Steering(st["delta_max_deg"], st["period"]),
            spin=Spin(mc["spin_threshold"], mc.get("spin_policy", "exclude")),
            speed=SpeedRamp(ramp["start_kmh"], ramp["end_kmh"], ramp["duration"], ramp.get("t_start", 0.0)) if ramp else None,
            noise_levels=tuple(config.get("noise", {}).get("levels", ())),
            identify=Identify(**{k: ident[k] for k in Identify.__dataclass_fields__ if k in ident}),
            discover=Discover.from_section(config.get("discrepancy", {})),
            samples=int(mc.get("samples", 2000)),
            bayes_prior=tuple(tuple(prior[n]) for n in ParameterLayout.names) if prior else (),
            control=Control(**{k: tuple(c[k]) if isinstance(c[k], list) else c[k] for k in Control.__dataclass_fields__ if k in c}),
            wheelslip=WheelSlipCar(**{k: ws[k] for k in WheelSlipCar.__dataclass_fields__ if k in ws}),
            ensemble_provenance=MappingProxyType(_provenance(config, time, veh.speed_kmh if speed is not None else None)),
        )

    def ensemble_hash(self, samples: int, seed: int, chunk: int | None = None) -> str:
        """:func:`ensemble_hash` of the config these settings were parsed from."""
        return _hash(dict(self.ensemble_provenance), samples, seed, chunk)

    @property
    def layout(self) -> ParameterLayout:
        """The distribution parameters' layout of this uncertainty."""
        return ParameterLayout.of(self.uncertainty)

    def with_time(self, time: TimeGrid) -> "Settings":
        """The same settings on another time grid."""
        return replace(self, time=time)

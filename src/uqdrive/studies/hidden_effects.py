"""Generator of "measured" single-track ensembles with a hidden physical effect, the ground truth
of a benchmark for discrepancy detection.

The "reality" is integrated here by its own vectorised fixed-step RK4 (over realisations, no
per-sample loop), independently of the LST/NLST code of :mod:`uqdrive.vehicle`: the stochastic
linear single-track model (linear tyres c_f alpha_f, c_r alpha_r, y_dot = v psi) with uncertain
mu, m_load, l_f and mean wind, KLE gusts (yaw moment M_c F_w as in the Monte Carlo ensembles)
and white measurement noise, plus switchable effects, each with a magnitude (one, or several at
once in a combined case):

==========================  ========================================================================
effect                      magnitude
==========================  ========================================================================
none                        0 (the model itself: the null case)
tyre_saturation             steering amplitude (deg); NLST of the thesis: Magic-Formula tyres
actuator_lag                time constant T (s) of a first-order steering lag
actuator_delay              pure steering delay tau (s)
road_bank                   bank angle phi (deg): lateral force m g sin(phi), no yaw moment
wind_gust                   factor on the config's gust std wind.sigma
lateral_kinematics          steering amplitude (deg); y_dot = v sin(psi + beta) instead of v psi (or v sin psi)
sensor_bias                 offset added to the measured ``channel`` (its SI unit)
sensor_scale                gain on the measured ``channel``
longitudinal_load_transfer  cg height h (m) of the load the body's a_x moves: F_zf = m (g l_r - a_x h) / L
lateral_load_transfer       each wheel's load sensitivity p_Dz (-); transfer h m a_y / t, 0.55 of it front
compliance_steer            K (deg/g): front steer -K per g of the front force over its static mass share
tyre_relaxation             relaxation length sigma (m) of both axles' slip angles
roll_steer                  K (deg/g): front steer -K per g through the body's roll (a 2.4 Hz roll mode)
==========================  ========================================================================

The chassis effects (:data:`CHASSIS_EFFECTS`; :mod:`.hidden.chassis`) give each tyre the slope
B C D of its wheel's load-dependent peak D; their cases are in the benchmark when discover may
name them (each chassis effect of the case among ``discrepancy.candidates``).

The command is either a smooth function of time (``hold: linear``) or its samples on the output
grid held between samples (``hold: previous``, a zero-order hold as a digital controller sends
it); the file's ``delta`` carries that as its ``interpolation`` attribute.

A generated dataset follows the uqdrive data schema and carries no label, no draws and no spin
flag; :func:`case_label` gives the label for a separate file.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from functools import lru_cache
from importlib import resources
from typing import TYPE_CHECKING, Any

import numpy as np
import yaml

from ..rng import rng_stream
from ..vehicle.channels import CHANNEL_NAMES, CHANNEL_UNITS, CHANNELS
from ..vehicle.single_track import STATES
from ..vehicle.uncertainty import KarhunenLoeve, kle_nystrom
from .hidden.reality import CHASSIS_EFFECTS, case_speed, reality_rhs, rk4_left_limit, speed_of_case, state_size
from .manoeuvres import MANOEUVRES, steering_command

if TYPE_CHECKING:
    import xarray as xr

__all__ = ["CHASSIS_EFFECTS", "EFFECTS", "MAGNITUDE_UNITS", "HiddenEffectCase", "benchmark_cases", "case_label", "draw_realisations", "generate", "measure",
           "simulate_states", "simulate_channels", "wind_kle"]

EFFECTS = ("none", "tyre_saturation", "actuator_lag", "actuator_delay", "road_bank", "wind_gust", "lateral_kinematics", "sensor_bias",
           "sensor_scale", *CHASSIS_EFFECTS)
AMPLITUDE_EFFECTS = ("tyre_saturation", "lateral_kinematics")  # magnitude = steering amplitude (deg)
#: Unit of each effect's magnitude (the table of the module docstring); sensor effects: the channel's.
MAGNITUDE_UNITS = {"none": "-", "tyre_saturation": "deg", "actuator_lag": "s", "actuator_delay": "s", "road_bank": "deg",
                   "wind_gust": "x sigma", "lateral_kinematics": "deg", "sensor_bias": "channel unit", "sensor_scale": "gain",
                   "longitudinal_load_transfer": "m", "lateral_load_transfer": "-", "compliance_steer": "deg/g",
                   "tyre_relaxation": "m", "roll_steer": "deg/g"}
SENSOR_EFFECTS = ("sensor_bias", "sensor_scale")
PARAMETERS = ("mu", "m_load", "l_f", "F_w_mean")
MAX_STEP = 0.005  # s, largest internal RK4 step


def _pairs(mapping) -> tuple:
    """Hashable, sorted ((key, value), ...) form of a mapping (or of such pairs)."""
    items = mapping.items() if isinstance(mapping, Mapping) else (mapping or ())
    return tuple(sorted((str(k), tuple(v) if isinstance(v, (list, tuple)) else v) for k, v in items))


@dataclass(frozen=True)
class HiddenEffectCase:
    """One benchmark case: a reality, a manoeuvre and the size of its ensemble.

    Attributes
    ----------
    name : str
        Case identifier (a label: keep it out of the measured file's name if the benchmark is blind).
    effect : str
        One of :data:`EFFECTS`.
    magnitude : float
        Size of the effect, in the unit of the table in the module docstring (0 for ``none``).
    manoeuvre : str
        One of :data:`uqdrive.studies.manoeuvres.MANOEUVRES`.
    manoeuvre_params : mapping
        Keyword arguments of the manoeuvre function (amplitude in ``amplitude_deg``); for
        tyre_saturation and lateral_kinematics the amplitude is the magnitude.
    samples, seed : int
        Number of realisations and root seed of the case's random streams.
    channel : str, optional
        Measured state hit by sensor_bias / sensor_scale (psi, psi_dot, beta or y).
    shift : mapping
        Parameter distributions replacing the config's: {"mu" | "m_load" | "l_f": (mean, std),
        "F_w_mean": (low, high)}, e.g. {"mu": (0.9, 0.15)}.
    noise : float
        Measurement-noise std of each channel as a fraction of its typical RMS (the median over
        realisations of the RMS over time of the clean signal).
    extra : sequence of (effect, magnitude, channel)
        Further hidden effects of a combined case (each at most once, none ``none``); channel
        None unless a sensor effect.
    hold : {"linear", "previous"}
        The command between output samples: the smooth manoeuvre, or each sample held.
    speed : mapping
        A changing speed: the keyword arguments of
        :func:`uqdrive.studies.manoeuvres.braking_in_turn_speed` (start_kmh, end_kmh, t_brake,
        duration); empty: the config's constant speed.
    """

    name: str
    effect: str
    magnitude: float
    manoeuvre: str
    manoeuvre_params: Any = ()
    samples: int = 1000
    seed: int = 0
    channel: str | None = None
    shift: Any = ()
    noise: float = 0.01
    extra: Any = ()
    hold: str = "linear"
    speed: Any = ()

    @property
    def effects(self) -> tuple:
        """Every hidden effect as (effect, magnitude, channel), the primary one first."""
        return ((self.effect, float(self.magnitude), self.channel),) + self.extra if self.effect != "none" else ()

    def size(self, effect: str, default: float = 0.0) -> float:
        """Magnitude of ``effect`` in this case (``default`` when absent)."""
        return next((m for e, m, _ in self.effects if e == effect), default)

    def __post_init__(self):
        extra = tuple((str(e), float(m), None if c is None else str(c)) for e, m, c in self.extra)
        object.__setattr__(self, "extra", extra)
        if self.hold not in ("linear", "previous"):
            raise ValueError(f"{self.name}: hold must be 'linear' or 'previous'; got '{self.hold}'")
        if extra and self.effect == "none":
            raise ValueError(f"{self.name}: a combined case has a primary effect other than 'none'")
        if any(e == "none" for e, _, _ in extra) or len({(e, c) for e, _, c in self.effects}) != len(self.effects):
            raise ValueError(f"{self.name}: the effects of a combined case are distinct and not 'none': {self.effects}")
        for e, m, c in extra:
            HiddenEffectCase(f"{self.name}/{e}", e, m, self.manoeuvre, self.manoeuvre_params, channel=c)  # each checked alone
        if self.effect not in EFFECTS:
            raise ValueError(f"unknown effect '{self.effect}'; choose one of {', '.join(EFFECTS)}")
        if self.manoeuvre not in MANOEUVRES:
            raise ValueError(f"unknown manoeuvre '{self.manoeuvre}'; choose one of {', '.join(MANOEUVRES)}")
        params = dict(_pairs(self.manoeuvre_params))
        if self.effect in AMPLITUDE_EFFECTS and params.setdefault("amplitude_deg", float(self.magnitude)) != self.magnitude:
            raise ValueError(f"{self.name}: the magnitude of {self.effect} is the steering amplitude; drop amplitude_deg")
        object.__setattr__(self, "manoeuvre_params", _pairs(params))
        object.__setattr__(self, "shift", _pairs(self.shift))
        object.__setattr__(self, "speed", _pairs(self.speed))
        unknown = set(dict(self.shift)) - set(PARAMETERS)
        if unknown:
            raise ValueError(f"{self.name}: shift of unknown parameters {sorted(unknown)}; known: {', '.join(PARAMETERS)}")
        if (self.channel is not None) != (self.effect in SENSOR_EFFECTS) or self.channel not in (None, *CHANNELS):
            raise ValueError(f"{self.name}: a channel ({', '.join(CHANNELS)}) is given for sensor effects, and only for them")
        if self.effect == "none" and self.magnitude != 0:
            raise ValueError(f"{self.name}: effect 'none' has magnitude 0")
        if self.effect in ("actuator_lag", "wind_gust", "sensor_scale") and self.magnitude <= 0:
            raise ValueError(f"{self.name}: {self.effect} needs a magnitude > 0")
        if self.effect == "actuator_delay" and self.magnitude < 0:
            raise ValueError(f"{self.name}: actuator_delay needs a magnitude >= 0")
        if self.effect in ("longitudinal_load_transfer", "tyre_relaxation") and self.magnitude <= 0:
            raise ValueError(f"{self.name}: {self.effect} needs a magnitude > 0 (m)")
        if self.effect == "lateral_load_transfer" and not -1.0 <= self.magnitude < 0.0:
            raise ValueError(f"{self.name}: lateral_load_transfer's magnitude is the load sensitivity p_Dz, in [-1, 0)")
        if self.effect in ("compliance_steer", "roll_steer") and self.magnitude == 0:
            raise ValueError(f"{self.name}: {self.effect} needs a magnitude other than 0 (deg/g)")
        if self.samples < 1 or self.noise < 0:
            raise ValueError(f"{self.name}: samples >= 1 and noise >= 0 required")


@lru_cache(maxsize=8)
def _kle_cached(t_end: float, Tc: float, n_quadrature: int, truncation: float) -> KarhunenLoeve:
    return kle_nystrom(0.0, t_end, Tc, n_quadrature, truncation)


def wind_kle(config: Mapping[str, Any]) -> KarhunenLoeve:
    """KLE of the unit side wind on [0, t_end] (cached: one eigenproblem per setting)."""
    w = config["wind"]
    return _kle_cached(float(config["time"]["t_end"]), float(w["Tc"]), int(w["kle_quadrature"]), float(w["kle_truncation"]))


def _distributions(config: Mapping[str, Any], case: HiddenEffectCase) -> dict[str, tuple[float, float]]:
    u = config["uncertainty"]
    dist = {name: (u[name]["mean"], u[name]["std"]) for name in ("mu", "m_load", "l_f")}
    dist["F_w_mean"] = (u["F_w_mean"]["low"], u["F_w_mean"]["high"])
    dist.update({k: tuple(map(float, v)) for k, v in case.shift})
    return dist


def draw_realisations(config: Mapping[str, Any], case: HiddenEffectCase, kle: KarhunenLoeve | None = None) -> dict[str, np.ndarray]:
    """Per-realisation draws of a case: mu, m_load, l_f (normal), F_w_mean (uniform), all of
    shape (samples,), and ``xi_wind`` (samples, n_modes), the standard normal KLE germs.

    Streams "hidden_parameters" and "hidden_wind" of ``case.seed``.
    """
    n, kle = int(case.samples), wind_kle(config) if kle is None else kle
    dist = _distributions(config, case)
    rng = rng_stream(case.seed, "hidden_parameters")
    z = rng.standard_normal((3, n))
    draws = {name: dist[name][0] + dist[name][1] * z[i] for i, name in enumerate(("mu", "m_load", "l_f"))}
    draws["F_w_mean"] = rng.uniform(*dist["F_w_mean"], size=n)
    draws["xi_wind"] = rng_stream(case.seed, "hidden_wind").standard_normal((n, kle.n_modes))
    return draws


def _time_grid(config: Mapping[str, Any], max_step: float = MAX_STEP):
    """Output times, RK4 step h <= max_step dividing the output step, and the substeps."""
    t_end, dt = float(config["time"]["t_end"]), float(config["time"]["dt"])
    substeps = int(np.ceil(dt / min(float(config["time"]["step"]), max_step) - 1e-9))
    n_out = round(t_end / dt)
    return np.arange(n_out + 1) * dt, dt / substeps, substeps


def _actual_steering(case: HiddenEffectCase, t, dt: float, left: bool = False) -> np.ndarray:
    """Steering at the wheels before any lag: the command (held between the output samples
    i dt for ``hold: previous``), delayed by tau for actuator_delay (zero before). ``left``:
    the limit from the left at a held command's jumps (the value a step ending there saw)."""
    params = dict(case.manoeuvre_params)
    shifted = np.asarray(t, float) - case.size("actuator_delay")
    if case.hold == "previous":
        shifted = (np.ceil(shifted / dt - 1e-9) - 1.0 if left else np.floor(shifted / dt + 1e-9)) * dt
    started = shifted > -1e-9
    return np.where(started, steering_command(case.manoeuvre, np.maximum(shifted, 0.0), params), 0.0)


def simulate_states(config: Mapping[str, Any], case: HiddenEffectCase, draws=None, kle: KarhunenLoeve | None = None):
    """Clean (noise- and sensor-error-free) response of the case's reality.

    ``config``: validated (vehicle, tyre, uncertainty, wind, time); ``draws``: output of
    :func:`draw_realisations` and ``kle`` the unit wind's KLE on [0, t_end] (made if omitted).

    Returns
    -------
    t, delta : ndarray, shape (T,)
        Output times (s) and commanded steering angle (rad).
    x : ndarray, shape (4, samples, T)
        True states psi, psi_dot, beta, y.
    """
    t, delta, x, _, _ = simulate_channels(config, case, draws, kle)
    return t, delta, x


def simulate_channels(config: Mapping[str, Any], case: HiddenEffectCase, draws=None, kle: KarhunenLoeve | None = None):
    """:func:`simulate_states` with the lateral acceleration and the speed.

    Returns
    -------
    t, delta, x
        As :func:`simulate_states`.
    a_y : ndarray, shape (samples, T)
        Clean accelerometer reading at the centre of gravity (m/s^2): the lateral tyre and wind
        forces over the mass.
    v : ndarray, shape (T,)
        Speed (m/s): the config's constant one, or the case's braking profile.
    """
    kle = wind_kle(config) if kle is None else kle
    draws = draw_realisations(config, case, kle) if draws is None else draws
    sigma, v_max = case.size("tyre_relaxation"), float(case_speed(config, case, np.zeros(1))[0])  # the speed at the start
    # a slip lag's time constant sigma / v spans at least two RK4 steps (|h lambda| <= 0.5)
    t, h, substeps = _time_grid(config, min(MAX_STEP, 0.5 * sigma / v_max) if sigma > 0 else MAX_STEP)
    n_steps = (t.size - 1) * substeps
    t_half = np.arange(2 * n_steps + 1) * (0.5 * h)
    sigma = float(config["wind"]["sigma"]) * case.size("wind_gust", 1.0)
    coeffs = sigma * np.asarray(draws["xi_wind"]) * np.sqrt(kle.eigenvalues)  # (n, n_c), thesis (5.21)
    gust_half = np.ascontiguousarray((coeffs @ kle.eigenfunctions(t_half)).T)  # (n_half, n)
    dt = float(t[1] - t[0])
    delta_half = _actual_steering(case, t_half, dt)
    delta_left = _actual_steering(case, t_half, dt, left=True) if case.hold == "previous" else None
    n = np.shape(draws["mu"])[0]
    x0 = np.zeros((state_size(case), n))
    speed_half = speed_of_case(config, case, t_half) if case.speed else None
    rhs = reality_rhs(config, case, draws, delta_half, gust_half, delta_left, speed_half)
    full = rk4_left_limit(rhs, x0, h, n_steps, substeps)  # (T, state_size, n)
    a_y = np.stack([rhs.a_y(full[k], 2 * k * substeps) for k in range(t.size)], axis=-1)
    delta = steering_command(case.manoeuvre, t, dict(case.manoeuvre_params))
    v = case_speed(config, case, t)
    return t, delta, np.ascontiguousarray(full[:, :4].transpose(1, 2, 0)), a_y, v


def measure(case: HiddenEffectCase, x, a_y=None) -> np.ndarray:
    """Measured channels: sensor effect of the case plus white Gaussian noise.

    Each channel gets noise of std ``case.noise`` times its typical RMS (median over
    realisations of the RMS over time of the true signal; the median keeps realisations that
    lost control from inflating it), drawn from stream "hidden_noise" of ``case.seed``; the
    noise germs do not depend on the effect, so cases differing only in a sensor error share them.
    The lateral acceleration's noise is drawn after the states' (the states' stay as without it).

    Parameters
    ----------
    x : ndarray, shape (4, samples, T)
    a_y : ndarray, shape (samples, T), optional

    Returns
    -------
    ndarray, shape (4, samples, T), or (5, samples, T) with a_y last
    """
    rng = rng_stream(case.seed, "hidden_noise")
    signals = list(x) + ([] if a_y is None else [np.asarray(a_y)])
    out = np.empty((len(signals),) + x.shape[1:])
    for i, (name, xi) in enumerate(zip(CHANNELS, signals)):
        zeta = rng.standard_normal(xi.shape)
        scale = case.noise * np.median(np.sqrt(np.mean(xi ** 2, axis=-1)))
        gain = next((m for e, m, c in case.effects if e == "sensor_scale" and c == name), 1.0)
        offset = next((m for e, m, c in case.effects if e == "sensor_bias" and c == name), 0.0)
        out[i] = gain * xi + offset + scale * zeta
    return out


def generate(config: Mapping[str, Any], case: HiddenEffectCase, kle: KarhunenLoeve | None = None, channels=STATES) -> xr.Dataset:
    """Measured ensemble of a case in the uqdrive data schema (``io.validate_ensemble``).

    The ``channels`` (any of psi, psi_dot, beta, y and a_y, the accelerometer's reading in
    m/s^2) over (sample, time) and the commanded steering ``delta`` (time), coordinate time
    (s), attribute v_c (m/s), or a variable ``v`` (time) for a case with a speed profile; no
    label, draws, noise level or spin flag.
    """
    import xarray as xr  # here, not above: the workflow lists the cases while it parses its rules

    unknown = [c for c in channels if c not in CHANNELS]
    if unknown or not channels:
        raise ValueError(f"channels {list(channels)}: choose a non-empty subset of {', '.join(CHANNELS)}")
    t, delta, x, a_y, v = simulate_channels(config, case, kle=kle)
    y = measure(case, x, a_y if "a_y" in channels else None)
    data_vars = {
        name: (("sample", "time"), y[CHANNELS.index(name)], {"units": CHANNEL_UNITS[name], "long_name": f"measured {CHANNEL_NAMES[name]}"})
        for name in CHANNELS if name in channels
    }
    data_vars["delta"] = ("time", delta, {"units": "rad", "long_name": "commanded front steering angle", "interpolation": case.hold})
    coords = {"sample": np.arange(x.shape[1]), "time": ("time", t, {"units": "s", "long_name": "time"})}
    attrs = {"title": "measured single-track ensemble"}
    if case.speed:
        data_vars["v"] = ("time", v, {"units": "m/s", "long_name": "vehicle speed"})
    else:
        attrs["v_c"] = float(config["vehicle"]["speed_kmh"]) / 3.6
    return xr.Dataset(data_vars, coords=coords, attrs=attrs)


def case_label(case: HiddenEffectCase) -> dict[str, Any]:
    """Ground-truth label of a case, for a labels file kept apart from the measured data."""
    return {
        "name": case.name,
        "effect": case.effect,
        "effects": [{"effect": e, "magnitude": m, "channel": c} for e, m, c in case.effects],
        "hold": case.hold,
        "discrepant": case.effect != "none",
        "magnitude": float(case.magnitude),
        "channel": case.channel,
        "manoeuvre": case.manoeuvre,
        "manoeuvre_params": {k: v for k, v in case.manoeuvre_params},
        "seed": int(case.seed),
        "samples": int(case.samples),
        "noise": float(case.noise),
        "shift": {k: list(v) for k, v in case.shift},
    }


def _case_tables() -> dict:
    """The case tables of ``hidden_cases.yaml`` (package data)."""
    return yaml.safe_load(resources.files("uqdrive.studies").joinpath("hidden_cases.yaml").read_text())


def benchmark_cases(config: Mapping[str, Any], samples: int | None = None) -> list[HiddenEffectCase]:
    """The benchmark: six ``none`` cases (different seeds, manoeuvres, shifted distributions),
    every other effect but the chassis ones at two magnitudes off the thesis slalom, six combined
    cases, three ``none`` cases with a held pulse or step at 300 realisations or fewer, the chassis
    cases (at held speed, braking in a turn, the roll steer) whose chassis effects are all in
    ``discrepancy.candidates``, and "thesis_nlst", the
    thesis' own NLST reality (tyre_saturation, slalom 5 deg / 4 s, config distributions, root seed).
    Seeds: root + 101 + the position in the tables' order, included or not (new cases go last).

    Parameters
    ----------
    samples : int, optional
        Realisations per case (config ``montecarlo.samples`` by default).
    """
    n = int(config["montecarlo"]["samples"] if samples is None else samples)
    root, tables = int(config["seed"]), _case_tables()
    cases = [
        HiddenEffectCase(name, effect, size, manoeuvre, params, n, root + 101 + i, channel, shift, noise)
        for i, (name, effect, size, manoeuvre, params, channel, shift, noise) in enumerate(tables["single"])
    ]
    start = root + 101 + len(tables["single"])
    for i, (name, effects, manoeuvre, params, shift, noise) in enumerate(tables["combined"]):
        (effect, size, channel), extra = effects[0], effects[1:]
        cases.append(HiddenEffectCase(name, effect, size, manoeuvre, params, n, start + i, channel, shift, noise, extra=extra))
    start += len(tables["combined"])
    for i, (name, manoeuvre, params, held_samples, shift, noise) in enumerate(tables["held_null"]):
        cases.append(HiddenEffectCase(name, "none", 0.0, manoeuvre, params, min(n, held_samples), start + i, None, shift, noise, hold="previous"))
    start += len(tables["held_null"])
    chassis = [HiddenEffectCase(name, effect, size, manoeuvre, params, n, start + i, channel, shift, noise)
               for i, (name, effect, size, manoeuvre, params, channel, shift, noise) in enumerate(tables["chassis"])]
    start += len(tables["chassis"])
    for i, (name, effects, manoeuvre, params, *speed, shift, noise) in enumerate(tables["chassis_combined"] + tables["chassis_speed"]
                                                                                 + tables["chassis_roll"]):
        (effect, size, channel), extra = effects[0], effects[1:]  # a chassis_speed row holds the speed profile before the shift
        chassis.append(HiddenEffectCase(name, effect, size, manoeuvre, params, n, start + i, channel, shift, noise, extra=extra, speed=(speed or [()])[0]))
    candidates = set(CHASSIS_EFFECTS) if config["discrepancy"]["candidates"] == "all" else set(config["discrepancy"]["candidates"])
    cases += [c for c in chassis if {e for e, _, _ in c.effects if e in CHASSIS_EFFECTS} <= candidates]
    st = config["steering"]
    thesis = HiddenEffectCase("thesis_nlst", "tyre_saturation", float(st["delta_max_deg"]), "slalom",
                              {"period": float(st["period"])}, n, root, noise=0.01)
    return cases + [thesis]

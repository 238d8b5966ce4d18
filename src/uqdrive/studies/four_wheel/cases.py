"""Measured ensembles of the four-wheel reality (:mod:`uqdrive.vehicle.four_wheel`) for the
discovery benchmark: steady (step steer) and changing (slalom, chirp) inputs at set fractions of
the car's lateral-acceleration limit.

A realisation draws mu, m_load, l_f (normal) and the mean wind (uniform) from the config's
``uncertainty`` section and the KLE gusts from ``wind``, as the Monte Carlo ensembles do; the
four-wheel car's own constants (roll, pitch, tyre load dependence, relaxation, roll steer, speed
controller) are :class:`~uqdrive.vehicle.four_wheel.FourWheelCar`'s. A generated file follows
the uqdrive data schema and carries no label: :func:`case_label` is for a separate file.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Mapping

import numpy as np

from ...rng import rng_stream
from ...vehicle.four_wheel import FourWheelCar, simulate_four_wheel
from ...vehicle.four_wheel.model import PSI, R, VX, VY, Y
from ...vehicle.single_track import STATE_NAMES, STATE_UNITS, STATES
from ...vehicle.uncertainty import kle_of_wind
from ..manoeuvres import MANOEUVRES, steering_command
from ...settings import Settings

if TYPE_CHECKING:
    import xarray as xr

__all__ = ["FourWheelCase", "four_wheel_cases", "steady_limit", "amplitude_for", "simulate_case", "generate", "case_label", "output_grid",
           "add_noise", "measured_dataset"]

STEP = 0.005  # s, RK4 step of the reality (the roll, pitch and slip-lag modes need < 0.02 s)
STREAM_KEY = 4  # keys the hidden-effect streams apart from the single-track benchmark's


@dataclass(frozen=True)
class FourWheelCase:
    """One four-wheel case.

    Attributes
    ----------
    name : str
        Identifier (a label: keep it out of the measured file's name for a blind run).
    manoeuvre : str
        One of :data:`uqdrive.studies.manoeuvres.MANOEUVRES`.
    level : float
        Peak lateral acceleration of the nominal car (mu, m_load, l_f at their means, no wind)
        as a fraction of its steady limit (:func:`steady_limit`); sets the steering amplitude.
    manoeuvre_params : tuple of (key, value)
        Other keyword arguments of the manoeuvre (not the amplitude).
    samples, seed : int
    t_end : float
        Duration (s); the output step is the config's ``time.dt``.
    noise : float
        Measurement-noise std per channel as a fraction of its typical RMS (as the single-track
        benchmark's).
    """

    name: str
    manoeuvre: str
    level: float
    manoeuvre_params: Any = ()
    samples: int = 500
    seed: int = 0
    t_end: float = 10.0
    noise: float = 0.01

    def __post_init__(self):
        if self.manoeuvre not in MANOEUVRES:
            raise ValueError(f"unknown manoeuvre '{self.manoeuvre}'; choose one of {', '.join(MANOEUVRES)}")
        if not 0.0 < self.level < 1.0:
            raise ValueError(f"{self.name}: level is a fraction of the limit in (0, 1); got {self.level}")
        object.__setattr__(self, "manoeuvre_params", tuple(sorted(dict(self.manoeuvre_params).items())))


def output_grid(dt: float, t_end: float, step: float):
    """Output times (s) every ``dt`` up to ``t_end``, the RK4 step (s) at most ``step`` that divides
    ``dt``, the steps per output and the number of steps."""
    every = int(np.ceil(dt / step - 1e-9))
    n_out = round(t_end / dt)
    return np.arange(n_out + 1) * dt, dt / every, every, n_out * every


def _grid(config, t_end):
    return output_grid(float(config["time"]["dt"]), t_end, STEP)


def _nominal_run(config, car, delta_half, h, n_steps, every):
    """Nominal realisations (one per column of ``delta_half`` (J, k)), no wind: max |a_y| (k,)."""
    u = config["uncertainty"]
    k = delta_half.shape[1]
    zero = np.zeros_like(delta_half)
    v = np.full(delta_half.shape[0], Settings.from_config(config).vehicle.v_c)
    _, ex = simulate_four_wheel(car, np.full(k, u["mu"]["mean"]), np.full(k, u["m_load"]["mean"]), np.full(k, u["l_f"]["mean"]),
                                delta_half, v, zero, zero, h, n_steps, every)
    return np.abs(ex["a_y"]).max(axis=-1)


def steady_limit(config: Mapping[str, Any], car: FourWheelCar) -> float:
    """The nominal car's largest lateral acceleration (m/s^2) in a slow ramp steer to 30 deg
    over 15 s (quasi-steady; the front axle saturates first in this understeering car)."""
    _, h, every, _ = _grid(config, 12.0)
    n_steps = int(round(12.0 / h))
    t_half = np.arange(2 * n_steps + 1) * h / 2
    d = np.deg2rad(30.0) * np.clip(t_half / 15.0, 0.0, 1.0)
    return float(_nominal_run(config, car, d[:, None], h, n_steps, every)[0])


def amplitude_for(config: Mapping[str, Any], car: FourWheelCar, case: FourWheelCase, limit: float) -> float:
    """Steering amplitude (deg) at which the nominal car's peak |a_y| is ``case.level * limit``:
    30 amplitudes simulated at once, interpolated (peak a_y rises monotonically with it)."""
    t, h, every, n_steps = _grid(config, case.t_end)
    t_half = np.arange(2 * n_steps + 1) * h / 2
    amplitudes = np.linspace(0.1, 12.0, 30)
    params = dict(case.manoeuvre_params)
    d = np.stack([steering_command(case.manoeuvre, t_half, {**params, "amplitude_deg": a}) for a in amplitudes], axis=1)
    peak = _nominal_run(config, car, d, h, n_steps, every)
    top = int(np.argmax(peak))  # beyond it the car is past its limit
    return float(np.interp(case.level * limit, peak[: top + 1], amplitudes[: top + 1]))


def simulate_case(config: Mapping[str, Any], case: FourWheelCase, amplitude_deg: float, car: FourWheelCar | None = None):
    """Clean states of a case.

    Returns
    -------
    t : ndarray, shape (T,)
    delta : ndarray, shape (T,)
        Commanded steering (rad).
    x : ndarray, shape (4, samples, T)
        psi, psi_dot, beta = atan(vy / vx), y (rad, rad/s, rad, m).
    a_y : ndarray, shape (samples, T)
        Lateral acceleration (m/s^2).
    draws : dict
        mu, m_load, l_f, F_w_mean (samples,).
    """
    settings = Settings.from_config(config)
    car = FourWheelCar.from_vehicle(settings.vehicle) if car is None else car
    u, w = config["uncertainty"], config["wind"]
    n = int(case.samples)
    rng = rng_stream(case.seed, "hidden_parameters", STREAM_KEY)
    z = rng.standard_normal((3, n))
    draws = {name: u[name]["mean"] + u[name]["std"] * z[i] for i, name in enumerate(("mu", "m_load", "l_f"))}
    draws["F_w_mean"] = rng.uniform(u["F_w_mean"]["low"], u["F_w_mean"]["high"], size=n)
    L = car.wheelbase
    mu, l_f = np.maximum(draws["mu"], 0.05), np.clip(draws["l_f"], 0.05 * L, 0.95 * L)  # as the model's draws
    kle = kle_of_wind(settings.wind, case.t_end)  # over the case's own horizon
    xi = rng_stream(case.seed, "hidden_wind", STREAM_KEY).standard_normal((n, kle.n_modes))
    t, h, every, n_steps = _grid(config, case.t_end)
    t_half = np.arange(2 * n_steps + 1) * h / 2
    coeffs = float(w["sigma"]) * xi * np.sqrt(kle.eigenvalues)
    gust = (coeffs @ kle.eigenfunctions(t_half)).T  # (J, n)
    F_w = draws["F_w_mean"] + gust
    M_w = car.M_c * (F_w if w["gust_yaw_moment"] else np.broadcast_to(draws["F_w_mean"], F_w.shape))
    params = {**dict(case.manoeuvre_params), "amplitude_deg": amplitude_deg}
    d_half = steering_command(case.manoeuvre, t_half, params)
    v = np.full(t_half.size, settings.vehicle.v_c)
    s, ex = simulate_four_wheel(car, mu, draws["m_load"], l_f, d_half, v, F_w, M_w, h, n_steps, every)
    x = np.stack([s[PSI], s[R], np.arctan2(s[VY], s[VX]), s[Y]])
    return t, steering_command(case.manoeuvre, t, params), x, ex["a_y"], draws


def add_noise(x, noise: float, seed: int, stream_key: int):
    """``x`` (channel, sample, time) with white noise of std ``noise`` x the median RMS of each
    channel (stream "hidden_noise", ``seed``, ``stream_key``)."""
    rng = rng_stream(seed, "hidden_noise", stream_key)
    out = np.empty_like(x)
    for i in range(x.shape[0]):
        scale = noise * np.median(np.sqrt(np.mean(x[i] ** 2, axis=-1)))
        out[i] = x[i] + scale * rng.standard_normal(x[i].shape)
    return out


def measured_dataset(t, delta, y, v_c: float) -> xr.Dataset:
    """The uqdrive data schema of measured channels ``y`` (psi, psi_dot, beta, y, a_y; sample, time),
    the commanded steering ``delta`` (time, rad) and the speed ``v_c`` (m/s)."""
    import xarray as xr

    data = {name: (("sample", "time"), y[i], {"units": STATE_UNITS[name], "long_name": f"measured {STATE_NAMES[name]}"})
            for i, name in enumerate(STATES)}
    data["a_y"] = (("sample", "time"), y[4], {"units": "m/s^2", "long_name": "measured lateral acceleration"})
    data["delta"] = ("time", delta, {"units": "rad", "long_name": "commanded front steering angle"})
    coords = {"sample": np.arange(y.shape[1]), "time": ("time", t, {"units": "s", "long_name": "time"})}
    return xr.Dataset(data, coords=coords, attrs={"title": "measured ensemble", "v_c": v_c})


def generate(config: Mapping[str, Any], case: FourWheelCase, amplitude_deg: float, car: FourWheelCar | None = None) -> xr.Dataset:
    """Measured ensemble in the uqdrive data schema: psi, psi_dot, beta, y (sample, time), the
    commanded ``delta`` (time), attribute v_c (m/s); also the measured lateral acceleration
    ``a_y`` (sample, time). No label, draws or car constants."""
    t, delta, x, a_y, _ = simulate_case(config, case, amplitude_deg, car)
    y = add_noise(np.concatenate([x, a_y[None]]), case.noise, case.seed, STREAM_KEY)
    return measured_dataset(t, delta, y, Settings.from_config(config).vehicle.v_c)


def case_label(case, amplitude_deg: float, limit: float, car) -> dict[str, Any]:
    """Ground truth of a reality's ``case`` (its name, manoeuvre, level, samples, seed, t_end,
    noise) and ``car`` (a dataclass) for a labels file kept apart from the data."""
    from dataclasses import asdict

    return {"name": case.name, "manoeuvre": case.manoeuvre, "manoeuvre_params": dict(case.manoeuvre_params), "level": case.level,
            "amplitude_deg": amplitude_deg, "steady_limit_m_s2": limit, "samples": case.samples, "seed": case.seed,
            "t_end": case.t_end, "noise": case.noise, "car": asdict(car)}


#: name, manoeuvre, level (of the steady limit), manoeuvre parameters, duration (s); the steps
#: end after 5 s of steady cornering (the heading has turned by 0.6-1.9 rad by then)
_CASES = [
    ("fw_step_030", "step", 0.3, {"ramp": 0.4}, 6.0),
    ("fw_step_060", "step", 0.6, {"ramp": 0.4}, 6.0),
    ("fw_step_090", "step", 0.9, {"ramp": 0.4}, 6.0),
    ("fw_slalom_050", "slalom", 0.5, {"period": 4.0}, 10.0),
    ("fw_slalom_090", "slalom", 0.9, {"period": 4.0}, 10.0),
    ("fw_chirp_060", "chirp", 0.6, {}, 10.0),
]


def four_wheel_cases(config: Mapping[str, Any], samples: int = 500) -> list[FourWheelCase]:
    """The four-wheel benchmark: step steer (steady) at 0.3, 0.6, 0.9 of the steady limit, the
    thesis' slalom (4 s) at 0.5 and 0.9, and a chirp (0.1-1.5 Hz) at 0.6; seeds from the root."""
    root = int(config["seed"])
    return [FourWheelCase(name, manoeuvre, level, params, samples, root + 401 + i, t_end)
            for i, (name, manoeuvre, level, params, t_end) in enumerate(_CASES)]

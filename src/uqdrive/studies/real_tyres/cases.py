"""Measured ensembles of the Pacejka single-track reality (:mod:`uqdrive.vehicle.realities`): a
step steer and the thesis' slalom at 0.3, 0.6 and 0.9 of the car's lateral-acceleration limit, a
car whose tyres have another shape than the vehicle file's, and a multi-body-like car.

A run draws mu, m_load, l_f (normal) and the mean wind (uniform) from the config's ``uncertainty``
section and the KLE gusts from ``wind``, as the Monte Carlo ensembles do; the car's own tyres,
wheels and controller are :class:`~uqdrive.vehicle.realities.PacejkaCar`'s. A generated file
follows the uqdrive data schema and carries no label: :func:`case_label` is for a separate file.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Mapping

import numpy as np

from ...rng import rng_stream
from ...settings import Settings
from ...vehicle.realities import PacejkaCar, RollingCar, simulate_pacejka
from ..four_wheel.cases import add_noise, case_label, measured_dataset, output_grid
from ..hidden_effects import wind_kle
from ..manoeuvres import steering_command

if TYPE_CHECKING:
    import xarray as xr

__all__ = ["RealTyreCase", "REAL_TYRE_CASES", "CARS", "real_tyre_cases", "steady_limit", "amplitude_for", "simulate_case", "generate", "case_label"]

STEP = 0.002  # s, RK4 step: the wheels' slip mode has |h lambda| < 1 below it
STREAM_KEY = 5  # keys the streams apart from the other benchmarks'


@dataclass(frozen=True)
class RealTyreCase:
    """One case: ``name`` (a label), ``manoeuvre`` ("step" or "slalom"), ``level`` (the nominal
    car's peak |a_y| as a fraction of its steady limit), ``manoeuvre_params``, ``samples``,
    ``seed``, ``t_end`` (s), ``noise`` (measurement-noise std per channel, a fraction of its
    typical RMS) and ``car`` (a name of :data:`CARS`)."""

    name: str
    manoeuvre: str
    level: float
    manoeuvre_params: Any = ()
    samples: int = 200
    seed: int = 0
    t_end: float = 10.0
    noise: float = 0.01
    car: str = "sedan"

    def __post_init__(self):
        object.__setattr__(self, "manoeuvre_params", tuple(sorted(dict(self.manoeuvre_params).items())))


def _grid(config, t_end):
    return output_grid(float(config["time"]["dt"]), t_end, STEP)


def _speed(config) -> float:
    return Settings.from_config(config).vehicle.v_c


def _nominal_peak(config, car, delta_half, h, n_steps, every):
    """Peak |a_y| (k,) of the nominal car without wind, one run per column of ``delta_half`` (J, k)."""
    u = config["uncertainty"]
    k = delta_half.shape[1]
    zero = np.zeros_like(delta_half)
    _, a_y = simulate_pacejka(car, np.full(k, u["mu"]["mean"]), np.full(k, u["m_load"]["mean"]), np.full(k, u["l_f"]["mean"]), delta_half,
                              _speed(config), zero, zero, h, n_steps, every)
    return np.abs(a_y).max(axis=-1)


def steady_limit(config: Mapping[str, Any], car: PacejkaCar) -> float:
    """The nominal car's largest lateral acceleration (m/s^2) in a slow ramp steer to 20 deg over 15 s."""
    _, h, every, _ = _grid(config, 12.0)
    n_steps = int(round(12.0 / h))
    t_half = np.arange(2 * n_steps + 1) * h / 2
    return float(_nominal_peak(config, car, (np.deg2rad(20.0) * np.clip(t_half / 15.0, 0.0, 1.0))[:, None], h, n_steps, every)[0])


def amplitude_for(config: Mapping[str, Any], car: PacejkaCar, case: RealTyreCase, limit: float) -> float:
    """Steering amplitude (deg) at which the nominal car's peak |a_y| is ``case.level * limit``
    (24 amplitudes simulated at once, interpolated below the largest peak)."""
    _, h, every, n_steps = _grid(config, case.t_end)
    t_half = np.arange(2 * n_steps + 1) * h / 2
    amplitudes = np.linspace(0.1, 8.0, 24)
    params = dict(case.manoeuvre_params)
    d = np.stack([steering_command(case.manoeuvre, t_half, {**params, "amplitude_deg": a}) for a in amplitudes], axis=1)
    peak = _nominal_peak(config, car, d, h, n_steps, every)
    top = int(np.argmax(peak))
    return float(np.interp(case.level * limit, peak[: top + 1], amplitudes[: top + 1]))


def simulate_case(config: Mapping[str, Any], case: RealTyreCase, amplitude_deg: float, car: PacejkaCar = PacejkaCar()):
    """Clean channels of a case: times (T,), commanded steering (T,) (rad), states (4, samples, T)
    (psi, psi_dot, beta = atan(v_y / v_x), y), a_y (samples, T) (m/s^2), the draws (mu, m_load,
    l_f, F_w_mean, each (samples,)) and the rear wheel's slip (samples, T)."""
    u, w = config["uncertainty"], config["wind"]
    n = int(case.samples)
    rng = rng_stream(case.seed, "hidden_parameters", STREAM_KEY)
    z = rng.standard_normal((3, n))
    draws = {name: u[name]["mean"] + u[name]["std"] * z[i] for i, name in enumerate(("mu", "m_load", "l_f"))}
    draws["F_w_mean"] = rng.uniform(u["F_w_mean"]["low"], u["F_w_mean"]["high"], size=n)
    L = car.wheelbase
    mu, l_f = np.maximum(draws["mu"], 0.05), np.clip(draws["l_f"], 0.05 * L, 0.95 * L)  # as the model's draws
    kle = wind_kle({**config, "time": {**config["time"], "t_end": case.t_end}})
    xi = rng_stream(case.seed, "hidden_wind", STREAM_KEY).standard_normal((n, kle.n_modes))
    t, h, every, n_steps = _grid(config, case.t_end)
    t_half = np.arange(2 * n_steps + 1) * h / 2
    gust = ((float(w["sigma"]) * xi * np.sqrt(kle.eigenvalues)) @ kle.eigenfunctions(t_half)).T  # (J, n)
    F_w = draws["F_w_mean"] + gust
    M_w = car.M_c * (F_w if w["gust_yaw_moment"] else np.broadcast_to(draws["F_w_mean"], F_w.shape))
    params = {**dict(case.manoeuvre_params), "amplitude_deg": amplitude_deg}
    s, a_y = simulate_pacejka(car, mu, draws["m_load"], l_f, steering_command(case.manoeuvre, t_half, params), _speed(config), F_w, M_w,
                              h, n_steps, every)
    x = np.stack([s[0], s[1], np.arctan2(s[3], s[2]), s[4]])
    slip = car.wheel_radius * s[6] / s[2] - 1.0
    return t, steering_command(case.manoeuvre, t, params), x, a_y, draws, slip


def generate(config: Mapping[str, Any], case: RealTyreCase, amplitude_deg: float, car: PacejkaCar = PacejkaCar()) -> "xr.Dataset":
    """Measured ensemble in the uqdrive data schema: psi, psi_dot, beta, y and a_y (sample, time),
    the commanded ``delta`` (time), attribute v_c (m/s). No label, draws or car constants."""
    t, delta, x, a_y, _, _ = simulate_case(config, case, amplitude_deg, car)
    y = add_noise(np.concatenate([x, a_y[None]]), case.noise, case.seed, STREAM_KEY)
    return measured_dataset(t, delta, y, _speed(config))


#: The cars of the cases: the sedan (the vehicle file's chassis and tyre shape, load-sensitive tyres);
#: ``reshaped``, tyres whose own shape (B_f, B_r 1.45 times the file's, C 1.3, E -0.3) is not the
#: file's (1.9, 0.97) and otherwise ideal (peak and cornering stiffness proportional to the load);
#: ``rolling``, the sedan with a roll mode, roll camber on both axles and relaxing tyres;
#: ``roll_steering``, the rolling car whose front axle also toes out of the turn as the body rolls
#: (0.18 rad of kinematic roll steer per rad of roll on top of the camber's 0.12: 1.8 deg of front
#: steer per g where the rolling car has 0.72), the rear's camber unchanged.
CARS = {
    "sedan": PacejkaCar(),
    "reshaped": PacejkaCar(B_f=10.6 * 1.45, B_r=30.4 * 1.45, C=1.3, E=-0.3, p_Dz=0.0, q_Ky=1e6),
    "rolling": RollingCar(),
    "roll_steering": RollingCar(camber_slip_front=0.30),
}

#: name, manoeuvre, level (of the steady limit), manoeuvre parameters, duration (s), car
REAL_TYRE_CASES = [
    ("rt_step_030", "step", 0.3, {"ramp": 0.4}, 6.0, "sedan"),
    ("rt_step_060", "step", 0.6, {"ramp": 0.4}, 6.0, "sedan"),
    ("rt_step_090", "step", 0.9, {"ramp": 0.4}, 6.0, "sedan"),
    ("rt_slalom_030", "slalom", 0.3, {"period": 4.0}, 10.0, "sedan"),
    ("rt_slalom_060", "slalom", 0.6, {"period": 4.0}, 10.0, "sedan"),
    ("rt_slalom_090", "slalom", 0.9, {"period": 4.0}, 10.0, "sedan"),
    ("rt_shape_step_090", "step", 0.9, {"ramp": 0.4}, 6.0, "reshaped"),
    ("rt_roll_slalom_060", "slalom", 0.6, {"period": 2.0}, 8.0, "rolling"),
    ("rt_rollsteer_slalom_060", "slalom", 0.6, {"period": 2.0}, 8.0, "roll_steering"),
]


def real_tyre_cases(config: Mapping[str, Any], samples: int = 200) -> list[RealTyreCase]:
    """The cases, seeds from the config's root seed."""
    root = int(config["seed"])
    return [RealTyreCase(name, manoeuvre, level, params, samples, root + 501 + i, t_end, car=car)
            for i, (name, manoeuvre, level, params, t_end, car) in enumerate(REAL_TYRE_CASES)]

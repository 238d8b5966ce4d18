"""Recorded runs of a car for the import tests and benchmark: an independent linear single-track
simulator (scipy's solve_ivp, none of uqdrive's model code) and writers of MDF4, CSV and MATLAB logs.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

G = 9.80665
MANOEUVRE = 6.0      # s of steering
RECORD = 12.0        # s per recording
STEER_AMPLITUDE = np.deg2rad(1.0)  # rad at the road wheels
RATIO = 15.3         # hand-wheel per road-wheel angle
RATES = {"SteeringWheelAngle": 100.0, "YawRate": 50.0, "LatAcc": 100.0, "VehicleSpeed": 20.0}
MAP = {
    "psi_dot": {"channel": "YawRate", "units": "deg/s"},
    "a_y": {"channel": "LatAcc", "units": "g", "sign": -1},
    "delta": {"channel": "SteeringWheelAngle", "units": "deg", "steering_ratio": RATIO},
    "v": {"channel": "VehicleSpeed", "units": "km/h"},
    "time": {"channel": "Zeit_ms", "units": "ms"},
}


@dataclass(frozen=True)
class Car:
    """A single-track car: mass (kg), yaw inertia (kg m^2), l_f, l_r (m), axle stiffnesses at mu = 1 (N/rad)."""

    m: float = 1573.0
    I_z: float = 2873.0
    l_f: float = 1.1
    l_r: float = 1.58
    C_f: float = 160000.0
    C_r: float = 160000.0


def steering(tau, scale=1.0):
    """Road-wheel steering (rad) at manoeuvre time tau (s): two sines under a smooth 0.5 s ramp in and out."""
    tau = np.asarray(tau, float)
    ramp = np.clip(np.minimum(tau, MANOEUVRE - tau) / 0.5, 0.0, 1.0)
    window = np.sin(0.5 * np.pi * ramp) ** 2
    return scale * STEER_AMPLITUDE * window * (np.sin(2 * np.pi * 0.5 * tau) + 0.6 * np.sin(2 * np.pi * 1.2 * tau))


def simulate(mu, v: float, car: Car = Car(), scale=1.0):
    """Yaw rate (rad/s) and lateral acceleration (m/s^2, to the left) of runs as functions of manoeuvre time.

    Linear tyres F = mu C alpha; states side slip beta and yaw rate r per run (mu and scale: scalars
    or arrays of shape (n,)), straight driving before the manoeuvre; one solve_ivp for all runs.
    The functions return arrays of shape (n, len(tau)).
    """
    mu, scale = np.broadcast_arrays(np.atleast_1d(np.asarray(mu, float)), np.atleast_1d(np.asarray(scale, float)))
    n = mu.size

    def forces(t, beta, r):
        d = scale[:, None] * steering(t) if np.ndim(t) else scale * steering(t)
        mu_ = mu[:, None] if np.ndim(t) else mu
        return mu_ * car.C_f * (d - beta - car.l_f * r / v), mu_ * car.C_r * (-beta + car.l_r * r / v)

    def rhs(t, x):
        beta, r = x[:n], x[n:]
        F_f, F_r = forces(t, beta, r)
        return np.concatenate([(F_f + F_r) / (car.m * v) - r, (car.l_f * F_f - car.l_r * F_r) / car.I_z])

    sol = solve_ivp(rhs, (0.0, RECORD), np.zeros(2 * n), method="DOP853", rtol=1e-10, atol=1e-12, dense_output=True)

    def state(tau):
        tau = np.asarray(tau, float)
        x = np.where(tau > 0, sol.sol(np.clip(tau, 0.0, RECORD)), 0.0)
        return x[:n], x[n:]

    def yaw_rate(tau):
        return state(tau)[1]

    def lateral_acceleration(tau):
        F_f, F_r = forces(np.asarray(tau, float), *state(tau))
        return (F_f + F_r) / car.m

    return yaw_rate, lateral_acceleration


@dataclass
class Run:
    """One recorded run: its lead (s from the recording's start to the manoeuvre's), friction and channels."""

    lead: float
    mu: float
    v: float
    channels: dict = field(default_factory=dict)  # name -> (t (s, recording clock), values in the logger's unit)


def record(mu, v, lead, rng=None, noise=0.0, scale=1.0, duration=RECORD, car: Car = Car()) -> list:
    """Runs as a logger records them (hand-wheel degrees, deg/s, g with the lateral axis to the
    right, km/h), each starting ``lead`` s (array, shape (n,)) before its manoeuvre."""
    mu, lead, scale = np.broadcast_arrays(np.atleast_1d(mu), np.atleast_1d(lead), np.atleast_1d(scale))
    yaw_rate, a_y = simulate(mu, v, car, scale)
    runs = [Run(float(lead[i]), float(mu[i]), v) for i in range(mu.size)]
    for name, rate in RATES.items():
        t = np.arange(0.0, duration - 1e-9, 1.0 / rate)
        tau = t[None, :] - lead[:, None]
        if name == "SteeringWheelAngle":
            values = np.rad2deg(scale[:, None] * steering(tau)) * RATIO
        elif name == "YawRate":
            values = np.rad2deg(np.stack([yaw_rate(tau[i])[i] for i in range(mu.size)]))
        elif name == "LatAcc":
            values = -np.stack([a_y(tau[i])[i] for i in range(mu.size)]) / G
        else:
            values = np.full(tau.shape, v * 3.6)
        if noise and name != "VehicleSpeed":
            values = values + noise * np.std(values) * rng.standard_normal(values.shape)
        for run, x in zip(runs, values):
            run.channels[name] = (t, x)
    return runs


UNITS = {"SteeringWheelAngle": "deg", "YawRate": "deg/s", "LatAcc": "g", "VehicleSpeed": "km/h"}


def write_mdf(run: Run, path: Path) -> Path:
    """The run as an MDF4 file, each channel in its own group at its own rate."""
    from asammdf import MDF, Signal

    mdf = MDF(version="4.10")
    for name, (t, x) in run.channels.items():
        mdf.append([Signal(np.asarray(x, float), t, name=name, unit=UNITS.get(name, ""))])
    mdf.save(path, overwrite=True)
    mdf.close()
    return path


def write_csv(run: Run, path: Path, dialect: str = "en") -> Path:
    """The run as a CSV export: time in ms, one row per instant any channel is sampled, empty cells
    where a slower channel has none; ``en``: ',' and a decimal point, ``de``: ';' and a decimal comma."""
    sep, dec = (",", ".") if dialect == "en" else (";", ",")
    times = np.unique(np.concatenate([np.round(t * 1e3, 6) for t, _ in run.channels.values()]))
    names = list(run.channels)
    cols = []
    for name in names:
        t, x = run.channels[name]
        col = np.full(times.size, "", dtype=object)
        text = np.char.mod("%.10g", np.asarray(x, float))
        col[np.searchsorted(times, np.round(t * 1e3, 6))] = np.char.replace(text, ".", dec) if dec != "." else text
        cols.append(col)
    lines = [sep.join(["Zeit_ms", *names])]
    lines += [sep.join([f"{ms:.6g}".replace(".", dec), *(c[i] for c in cols)]) for i, ms in enumerate(times)]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def mat_records(items: list) -> np.ndarray:
    """A MATLAB struct array (1, n) of the dicts ``items`` (one set of fields), for scipy's savemat."""
    fields = list(items[0])
    out = np.empty((1, len(items)), dtype=[(f, object) for f in fields])
    for i, item in enumerate(items):
        out[0, i] = tuple(item[f] for f in fields)
    return out


def save_mat(path: Path, variables: dict, version: str) -> Path:
    """``variables`` as a MAT file: version "5" through scipy, "7.3" (HDF5) through hdf5storage."""
    if version == "7.3":
        import hdf5storage

        hdf5storage.savemat(str(path), variables, format="7.3", matlab_compatible=True)
    else:
        from scipy.io import savemat

        savemat(path, variables)
    return path


def time_axes(run: Run) -> tuple[list, dict]:
    """The run's distinct time axes, and each channel's index into them."""
    axes, index = [], {}
    for name, (t, _) in run.channels.items():
        k = next((i for i, a in enumerate(axes) if np.array_equal(a, t)), None)
        if k is None:
            axes.append(t)
            k = len(axes) - 1
        index[name] = k
    return axes, index


def write_dspace(run: Run, path: Path, version: str = "5") -> Path:
    """The run as a dSPACE ControlDesk recorder MAT file: X holds the rasters' times, Y the signals
    with their full names, units and the index of their raster."""
    axes, index = time_axes(run)
    X = mat_records([{"Name": f"Raster {k + 1}", "Data": t.reshape(1, -1)} for k, t in enumerate(axes)])
    Y = mat_records([{"Name": f'Model Root/Sensors/"{name}"/Out1', "Data": np.asarray(x, float).reshape(1, -1), "Unit": UNITS[name],
                      "XIndex": float(index[name] + 1)} for name, (_, x) in run.channels.items()])
    return save_mat(path, {"trace_0001": {"X": X, "Y": Y}}, version)


def write(run: Run, path: Path) -> Path:
    """By suffix: .mf4 -> MDF4, .csv -> English CSV, .de.csv -> German CSV, .mat -> dSPACE MAT v5,
    .v73.mat -> dSPACE MAT v7.3."""
    if path.suffix == ".mf4":
        return write_mdf(run, path)
    if path.suffix == ".mat":
        return write_dspace(run, path, "7.3" if path.name.endswith(".v73.mat") else "5")
    return write_csv(run, path, "de" if path.name.endswith(".de.csv") else "en")

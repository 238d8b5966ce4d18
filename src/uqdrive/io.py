"""Files at the edge of uqdrive: validation of ensembles in the shared data schema (dims, units,
dtypes, finite and physical values, spread, the car's speed) with messages that name the field and
the fix; the output side (paths checked before any work, atomic writes) is :mod:`uqdrive.outputs`.
"""

from __future__ import annotations

import math
import numbers
from pathlib import Path

import numpy as np
import xarray as xr

from .interrupts import shielded
from .outputs import OutputError, atomic_path, check_output_folder, check_replaced_folder, check_writable  # noqa: F401
from .outputs import write_csv_rows, write_dataset  # noqa: F401
from .vehicle.channels import CHANNEL_UNITS, CHANNELS

__all__ = ["DataError", "OutputError", "check_writable", "check_output_folder", "check_replaced_folder", "atomic_path", "write_csv_rows", "write_dataset",
           "read_ensemble", "validate_ensemble", "check_spread", "check_run_count", "present_channels", "speed_profile", "data_speed",
           "V_C_RANGE", "VALUE_LIMITS", "MIN_TIME_POINTS", "MIN_RUNS", "STANDARD_GRAVITY", "A_Y_UNITS"]

#: Vehicle speeds (m/s) a measured ensemble may carry in its ``v_c`` attribute.
V_C_RANGE = (0.5, 100.0)
#: Largest departure of one run's speed from the runs' mean, as a share of that mean: the model
#: drives every run at the mean, and the yaw-rate gain v / (L + K v^2) of a run this far away
#: already differs by about as much, more than the spread of the parameters it identifies.
RUN_SPEED_SPREAD = 0.2
#: Largest magnitude (SI units) of each variable: beyond it the numbers are not a vehicle's (a unit
#: or scale error). Angles of a spinning car grow, so psi and beta get room; delta is a wheel angle.
VALUE_LIMITS = {"psi": 1e4, "psi_dot": 1e3, "beta": 1e4, "y": 1e6, "a_y": 200.0, "delta": math.pi / 2}
#: A trajectory needs this many time points for a mean, a slope and a curvature.
MIN_TIME_POINTS = 3
#: Fewest runs identify and discover accept: below 10 the sample std of a channel is uncertain by
#: more than 1/sqrt(2 (n - 1)) = 24 % (n = 10), larger than the spreads the parameters make.
MIN_RUNS = 10
#: Standard gravity (m/s^2, ISO 80000-3): a lateral acceleration stored in g is converted with it.
STANDARD_GRAVITY = 9.80665
#: Spellings of m/s^2 accepted in the ``units`` attribute of ``a_y``.
A_Y_UNITS = ("m/s^2", "m/s2", "m s-2", "m/s**2", "m.s-2")


class DataError(ValueError):
    """A data file does not follow the uqdrive ensemble schema."""


def _check_time(ds: xr.Dataset, source: str) -> None:
    time = ds["time"]
    if time.dims != ("time",):
        raise DataError(f"{source}: coordinate 'time' has dims {time.dims}; expected ('time',)")
    if time.dtype.kind not in "fiu":
        raise DataError(f"{source}: coordinate 'time' has dtype {time.dtype}; store seconds since the start as float64 with units 's'")
    units = time.attrs.get("units", "s")
    if units != "s":
        raise DataError(f"{source}: coordinate 'time' has units '{units}'; convert it to seconds and set units 's'")
    t = time.values.astype(float)
    if t.size < MIN_TIME_POINTS:
        raise DataError(f"{source}: 'time' has {t.size} point(s); a trajectory needs at least {MIN_TIME_POINTS}: give the whole record")
    if not np.all(np.isfinite(t)):
        raise DataError(f"{source}: coordinate 'time' holds NaN or inf; give finite times in s")
    steps = np.diff(t)
    if np.any(steps <= 0) or not np.allclose(steps, steps[0], rtol=1e-6, atol=1e-12):
        raise DataError(f"{source}: 'time' must be a uniform, increasing grid; resample the data onto one")


def _check_values(name: str, values: np.ndarray, unit: str, source: str) -> None:
    if values.dtype.kind != "f":
        raise DataError(f"{source}: variable '{name}' has dtype {values.dtype}; store it as floating point "
                        f"(e.g. ds['{name}'] = ds['{name}'].astype('float64'))")
    n_nan = int(np.isnan(values).sum())
    if n_nan:
        raise DataError(f"{source}: variable '{name}' holds {n_nan} NaN values; remove or interpolate those samples")
    n_inf = int(np.isinf(values).sum())
    if n_inf:
        raise DataError(f"{source}: variable '{name}' holds {n_inf} infinite values; remove or repair those samples")
    largest = float(np.abs(values).max()) if values.size else 0.0
    if largest > VALUE_LIMITS[name]:
        raise DataError(f"{source}: variable '{name}' reaches |{name}| = {largest:.3g} {unit}, beyond the physical "
                        f"{VALUE_LIMITS[name]:.3g} {unit}; check its units and scale (SI: {unit})")


def present_channels(ds: xr.Dataset) -> tuple:
    """The measured channels of :data:`uqdrive.vehicle.channels.CHANNELS` that ``ds`` carries, in that order."""
    return tuple(c for c in CHANNELS if c in ds)


def check_spread(ds: xr.Dataset, source: str, mask: np.ndarray | None = None) -> None:
    """Each channel must vary: not zero everywhere, and not the same in every (used) realisation."""
    for name in present_channels(ds):
        x = ds[name].values if mask is None else ds[name].values[mask]
        if not np.any(x):
            raise DataError(f"{source}: variable '{name}' is zero everywhere; a measured ensemble needs the recorded response")
        if x.shape[0] >= 2 and np.all(x == x[:1]):
            which = "used realisation" if mask is not None else "realisation"
            raise DataError(f"{source}: variable '{name}' is identical in every {which}; an ensemble needs spread "
                            "across independent runs (give one run per sample)")


def check_run_count(n: int, source: str, command: str) -> None:
    """At least :data:`MIN_RUNS` runs, or a :class:`DataError` saying how many and why."""
    if n < MIN_RUNS:
        raise DataError(f"{source}: {n} run(s) (dimension 'sample'); {command} needs at least {MIN_RUNS}: the spread "
                        f"of fewer runs is too uncertain (the sample std is uncertain by 1/sqrt(2 (n - 1)), "
                        f"{1 / math.sqrt(2 * max(n - 1, 1)):.0%} at n = {n}) to tell the parameters apart; record more runs")


def _check_a_y_units(ds: xr.Dataset, source: str) -> xr.Dataset:
    """Lateral acceleration in m/s^2; a file in g is converted (and says so in ``conversions``)."""
    got = ds["a_y"].attrs.get("units")
    if got in A_Y_UNITS:
        return ds
    if got in ("g", "G", "g0", "g_n"):
        a_y = ds["a_y"] * STANDARD_GRAVITY
        a_y.attrs = dict(ds["a_y"].attrs, units="m/s^2")
        note = f"a_y converted from g to m/s^2 (x {STANDARD_GRAVITY} m/s^2, standard gravity)"
        attrs = dict(ds.attrs, conversions="; ".join(filter(None, [ds.attrs.get("conversions", ""), note])))
        return ds.assign(a_y=a_y).assign_attrs(attrs)
    raise DataError(f"{source}: variable 'a_y' has units '{got}'; give the lateral acceleration in 'm/s^2' (or 'g', "
                    "converted on reading): set ds['a_y'].attrs['units']")


def _check_speed(ds: xr.Dataset, source: str) -> None:
    """A ``v`` variable: dims (time,) or (sample, time), units m/s, finite and in :data:`V_C_RANGE`."""
    v = ds["v"]
    if v.dims not in (("time",), ("sample", "time")):
        raise DataError(f"{source}: variable 'v' has dims {v.dims}; give the speed over ('time',) or ('sample', 'time')")
    if v.attrs.get("units") != "m/s":
        raise DataError(f"{source}: variable 'v' has units '{v.attrs.get('units')}'; give the speed in 'm/s' "
                        "(km/h / 3.6) and set ds['v'].attrs['units'] = 'm/s'")
    values = v.values
    if values.dtype.kind != "f":
        raise DataError(f"{source}: variable 'v' has dtype {values.dtype}; store it as floating point")
    if not np.all(np.isfinite(values)):
        raise DataError(f"{source}: variable 'v' holds {int(np.sum(~np.isfinite(values)))} NaN or infinite values; "
                        "interpolate the speed over those samples")
    lo, hi = V_C_RANGE
    if np.any(values < lo) or np.any(values > hi):
        raise DataError(f"{source}: variable 'v' reaches {float(values.min()):g}..{float(values.max()):g} m/s, outside "
                        f"{lo:g}-{hi:g} m/s; the model needs a forward speed: give |v| in m/s (no reversing, no standstill)")
    if v.dims == ("sample", "time") and values.shape[0] > 1:
        mean = values.mean(axis=0)
        apart = float(np.max(np.abs(values - mean) / mean))
        if apart > RUN_SPEED_SPREAD:
            raise DataError(f"{source}: variable 'v': the runs' speeds depart from their mean by up to {100 * apart:.0f} % "
                            f"(at most {100 * RUN_SPEED_SPREAD:.0f} %: the model drives every run at the mean); "
                            "store the runs of similar speed in one file each")


def speed_profile(ds: xr.Dataset) -> np.ndarray | None:
    """The speed over time (m/s) of a validated ensemble: None when it is the constant ``v_c`` (or
    a ``v`` that never changes), else ``v`` over time (its mean over runs for (sample, time))."""
    if "v" not in ds:
        return None
    v = ds["v"].values
    v = v.mean(axis=0) if v.ndim == 2 else v
    return None if np.all(v == v[0]) else v


def data_speed(ds: xr.Dataset) -> tuple[float | None, str | None]:
    """The car's speed of an ensemble by the one rule every command follows: a variable ``v``
    (the speed as recorded) is the speed and a global attribute ``v_c`` beside it is ignored;
    without ``v``, ``v_c`` is the speed. Runs each at its own constant speed run at their mean.

    Returns
    -------
    speed : float or None
        The constant speed (m/s): ``v_c``, or the value of a ``v`` that never changes; None for a
        ``v`` that changes over time (a profile, see :func:`speed_profile`).
    ignored : str or None
        A note naming the ``v_c`` that was ignored because it differs from ``v``, and the mean
        taken of runs held at different constant speeds, else None.
    """
    if "v" not in ds:
        return float(ds.attrs["v_c"]), None
    v = np.asarray(ds["v"].values, float)
    profile = speed_profile(ds)
    speed = None if profile is not None else float(np.ravel(v)[0])
    said = []
    if speed is not None and not np.all(v == speed):  # runs at different constant speeds: the model runs at their mean
        speed = float(np.mean(v))
        said.append(f"the runs' constant speeds v differ ({float(v.min()):.4g}-{float(v.max()):.4g} m/s): the model runs at "
                    f"their mean {speed:.6g} m/s")
    v_c = ds.attrs.get("v_c")
    try:
        differs = v_c is not None and (speed is None or float(v_c) != speed)
    except (TypeError, ValueError):
        differs = True
    if differs:
        given = f"{float(v_c):.6g} m/s" if isinstance(v_c, numbers.Real) else repr(v_c)
        what = f"constant {speed:.6g} m/s" if speed is not None else f"a profile {float(v.min()):.4g}-{float(v.max()):.4g} m/s"
        said.append(f"the file's attribute v_c = {given} is ignored: its variable v ({what}) is the car's speed, for every command")
    return speed, "; ".join(said) or None


def _check_v_c(ds: xr.Dataset, source: str) -> None:
    if "v_c" not in ds.attrs:
        raise DataError(f"{source}: missing global attribute 'v_c' (vehicle speed in m/s); set ds.attrs['v_c']")
    v = ds.attrs["v_c"]
    if isinstance(v, np.ndarray) and v.ndim == 0:
        v = v.item()
    lo, hi = V_C_RANGE
    if isinstance(v, (bool, np.bool_)) or not isinstance(v, numbers.Real):
        raise DataError(f"{source}: global attribute 'v_c' is {v!r}; give one number, the speed in m/s ({lo:g}-{hi:g})")
    if not (math.isfinite(float(v)) and lo <= float(v) <= hi):
        raise DataError(f"{source}: global attribute 'v_c' = {float(v):g} m/s is outside the physical range {lo:g}-{hi:g} m/s; "
                        "give the vehicle speed in m/s")


def validate_ensemble(ds: xr.Dataset, source: str = "dataset") -> xr.Dataset:
    """Check an ensemble against the uqdrive schema; raise :class:`DataError` naming the fix.

    Required: dims ``sample`` (at least 2) and ``time``; a uniform, increasing, finite ``time``
    coordinate in s with at least :data:`MIN_TIME_POINTS` points; at least one channel of
    psi, psi_dot, beta, y, a_y (:data:`uqdrive.vehicle.channels.CHANNELS`) of dims (sample, time)
    with its SI ``units`` (a_y in 'g' is converted to m/s^2, noted in the ``conversions``
    attribute), floating point, finite and within :data:`VALUE_LIMITS`, each varying across
    realisations; a ``delta`` (time) variable in rad; the speed as a global attribute ``v_c``
    (m/s), one finite number in :data:`V_C_RANGE`, or a variable ``v`` over (time) or
    (sample, time) in m/s within that range (then ``v`` is the speed, ``v_c`` is not needed).
    An optional ``spun`` (sample) flag must hold 0/1. ``delta`` may carry the attribute
    ``interpolation``: how the command is reconstructed between its samples, ``linear``
    (default) or ``previous`` (each sample held until the next), used by every simulation of the
    file. Returns the (converted) dataset.
    """
    for dim in ("sample", "time"):
        if dim not in ds.dims:
            raise DataError(f"{source}: missing dimension '{dim}'; ensembles have dims (sample, time)")
    if "time" not in ds.coords:
        raise DataError(f"{source}: missing coordinate 'time' (seconds)")
    _check_time(ds, source)
    if ds.sizes["sample"] < 2:
        raise DataError(f"{source}: {ds.sizes['sample']} sample(s); mean and std need at least 2 realisations")
    if not present_channels(ds):
        raise DataError(f"{source}: no usable channel; give at least one of "
                        + ", ".join(f"'{c}' ({u})" for c, u in CHANNEL_UNITS.items()) + " over (sample, time)")
    if "a_y" in ds:
        ds = _check_a_y_units(ds, source)
    required = {c: CHANNEL_UNITS[c] for c in present_channels(ds)}
    required["delta"] = "rad"
    for name, unit in required.items():
        if name not in ds:
            raise DataError(f"{source}: missing variable '{name}' ({unit}); add it over {('time',) if name == 'delta' else ('sample', 'time')}")
        want = ("time",) if name == "delta" else ("sample", "time")
        if ds[name].dims != want:
            raise DataError(f"{source}: variable '{name}' has dims {ds[name].dims}; expected {want}")
        got = ds[name].attrs.get("units")
        if got != unit and not (name == "a_y" and got in A_Y_UNITS):
            raise DataError(f"{source}: variable '{name}' has units '{got}'; expected '{unit}' (convert it and set the attribute)")
        _check_values(name, ds[name].values, unit, source)
    interpolation = ds["delta"].attrs.get("interpolation", "linear")
    if interpolation not in ("linear", "previous"):
        raise DataError(f"{source}: variable 'delta' has interpolation '{interpolation}'; expected 'linear' (straight lines between "
                        "samples) or 'previous' (each sample held until the next)")
    check_spread(ds, source)
    if "v" in ds:
        _check_speed(ds, source)
        speed, _ = data_speed(ds)
        ds = ds.copy(deep=False)  # the speed of every reader: v_c is v's constant value, or absent for a profile
        ds.attrs = {**{k: a for k, a in ds.attrs.items() if k != "v_c"}, **({} if speed is None else {"v_c": speed})}
    else:
        _check_v_c(ds, source)
    if "spun" in ds:
        spun = ds["spun"]
        if spun.dims != ("sample",) or spun.dtype.kind not in "biuf" or not np.all(np.isin(spun.values, (0, 1))):
            raise DataError(f"{source}: variable 'spun' must be one 0/1 flag per sample; drop it (lost control is "
                            "detected from beta) or fix it")
    return ds


def read_ensemble(path: str | Path) -> xr.Dataset:
    """Open and validate an ensemble file (loaded into memory, file closed; times not decoded)."""
    path = Path(path)
    if not path.exists():
        raise DataError(f"ensemble file '{path}' does not exist")
    if not path.is_file():
        raise DataError(f"ensemble path '{path}' is not a file; give a netCDF file")
    try:
        with shielded(), xr.open_dataset(path, engine="netcdf4", decode_times=False, decode_timedelta=False) as ds:
            ds = ds.load()  # shielded: a signal there would leave netCDF4's file lock taken and the close waiting
    except Exception as exc:  # netCDF4/HDF5 raise many kinds; any of them means an unreadable file
        reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise DataError(f"'{path}' is not a readable netCDF file ({reason}); write it with xarray's to_netcdf") from exc
    return validate_ensemble(ds, str(path))

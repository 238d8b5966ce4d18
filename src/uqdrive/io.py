"""Files at the edge of uqdrive: atomic writes (no half-written output survives a failure, an
existing output is replaced only by intent), CSV tables from lists of rows, and validation of
ensembles in the shared data schema (dims, units, dtypes, finite and physical values, spread)
with messages that name the field and the fix.
"""

from __future__ import annotations

import csv
import math
import numbers
import os
import re
import socket
import tempfile
from contextlib import contextmanager
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np
import xarray as xr

from .vehicle.channels import CHANNEL_UNITS, CHANNELS

__all__ = ["DataError", "OutputError", "check_writable", "check_output_folder", "atomic_path", "write_csv_rows", "write_dataset",
           "read_ensemble", "validate_ensemble", "check_spread", "check_run_count", "present_channels", "speed_profile",
           "V_C_RANGE", "VALUE_LIMITS", "MIN_TIME_POINTS", "MIN_RUNS", "STANDARD_GRAVITY", "A_Y_UNITS"]

#: Vehicle speeds (m/s) a measured ensemble may carry in its ``v_c`` attribute.
V_C_RANGE = (0.5, 100.0)
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


class OutputError(OSError):
    """An output path cannot be written."""


def _existing_ancestor(path: Path) -> Path:
    """The nearest ancestor of ``path`` (itself excluded) that exists."""
    for parent in path.absolute().parents:
        if parent.exists():
            return parent
    return Path("/")


def check_writable(path: str | Path, overwrite: bool = True) -> Path:
    """Fail early, before any work, if ``path`` cannot be created in its folder.

    With ``overwrite=False`` an existing ``path`` is refused too (pass ``--force`` to replace it).
    """
    path = Path(path)
    parent = path.parent if str(path.parent) else Path(".")
    if path.is_dir():
        raise OutputError(f"output path '{path}' is a directory; give a file name")
    if not parent.is_dir():
        if parent.exists() or not _existing_ancestor(parent).is_dir():
            raise OutputError(f"output folder '{parent}' lies under a regular file, not a folder; choose another path")
        raise OutputError(f"output folder '{parent}' does not exist; create it first")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise OutputError(f"output folder '{parent}' is not writable; choose another path or fix its permissions")
    if not overwrite and path.exists():
        raise OutputError(f"output '{path}' exists; pass --force to replace it (atomically) or choose another path")
    return path


def check_output_folder(folder: str | Path, names: Sequence[str] = (), overwrite: bool = True) -> Path:
    """Check, without creating anything, that ``folder`` (created later if missing) can hold ``names``."""
    folder = Path(folder)
    if folder.exists() and not folder.is_dir():
        raise OutputError(f"output folder '{folder}' exists and is a regular file; choose another path")
    base = folder if folder.is_dir() else _existing_ancestor(folder)
    if not base.is_dir():
        raise OutputError(f"output folder '{folder}' lies under a regular file ('{base}'); choose another path")
    if not os.access(base, os.W_OK | os.X_OK):
        raise OutputError(f"folder '{base}' is not writable, so '{folder}' cannot be written; choose another path or fix its permissions")
    if not overwrite:
        for name in names:
            if (folder / name).exists():
                raise OutputError(f"output '{folder / name}' exists; pass --force to replace it (atomically) or choose another --out")
    return folder


_HOST = re.sub(r"[^A-Za-z0-9-]", "-", socket.gethostname()) or "host"


def _remove_stale_temporaries(path: Path) -> None:
    """Delete temporaries of ``path`` left by a killed writer on this host (its pid is gone)."""
    pattern = re.compile(rf"^\.{re.escape(path.name)}\.{re.escape(_HOST)}\.(\d+)\..*\.tmp$")
    try:
        entries = list(path.parent.iterdir())
    except OSError:
        return
    for entry in entries:
        match = pattern.match(entry.name)
        if not match:
            continue
        try:
            os.kill(int(match.group(1)), 0)
        except ProcessLookupError:
            entry.unlink(missing_ok=True)
        except (OSError, OverflowError):
            pass  # alive (or not ours to probe): leave it


@contextmanager
def atomic_path(path: str | Path, overwrite: bool = True):
    """Yield a temporary path beside ``path``; move it onto ``path`` only if the block succeeds.

    The temporary is removed on any exception (including KeyboardInterrupt and the CLI's signal
    exit). With ``overwrite=False`` the move fails if ``path`` appeared meanwhile (a hard link,
    atomic), so two runs writing the same output cannot both succeed silently.
    """
    path = check_writable(path, overwrite)
    _remove_stale_temporaries(path)
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.{_HOST}.{os.getpid()}.", suffix=".tmp", dir=path.parent)
    except OSError as exc:
        raise OutputError(f"cannot write in '{path.parent}': {exc.strerror or exc}") from exc
    os.close(fd)
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)  # mkstemp creates 0600; give the file the usual mode
    try:
        yield Path(tmp)
        if overwrite:
            os.replace(tmp, path)
        else:
            try:
                os.link(tmp, path)
            except FileExistsError:
                raise OutputError(f"output '{path}' was created by another run meanwhile; pass --force to replace it") from None
            except OSError:  # no hard links on this file system: check, then rename
                if path.exists():
                    raise OutputError(f"output '{path}' was created by another run meanwhile; pass --force to replace it") from None
                os.replace(tmp, path)
    except OutputError:
        raise
    except OSError as exc:
        raise OutputError(f"cannot write '{path}': {exc.strerror or exc}") from exc
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def write_csv_rows(rows: Sequence[Mapping[str, object]], path: str | Path) -> None:
    """Write a table given as rows (dicts) to a CSV file atomically.

    Parameters
    ----------
    rows : sequence of mapping
        The table's rows, at least one. The keys of the first row are the columns, in their
        order; a later row lacking one of them gets an empty cell there.
    path : str or Path
        CSV file to write; replaced only once the whole table is written.

    Raises
    ------
    ValueError
        If ``rows`` is empty (there would be no header) or a row has a key the first lacks.
    OutputError
        If ``path`` cannot be written.

    Notes
    -----
    The dialect is :mod:`csv`'s default ("excel": comma separated, ``\\r\\n`` line ends,
    minimal quoting); ``None`` is written empty and any other value as ``str(value)``.
    """
    rows = list(rows)
    if not rows:
        raise ValueError(f"no rows to write to '{path}': a CSV table needs at least one row for its header")
    with atomic_path(path) as tmp:
        with open(tmp, "w", newline="") as fh:
            writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
            writer.writeheader()
            writer.writerows(rows)


def write_dataset(ds: xr.Dataset, path: str | Path, overwrite: bool = True) -> None:
    """Write a dataset as netCDF4 (zlib-compressed variables) atomically (see :func:`atomic_path`)."""
    encoding = {name: {"zlib": True, "complevel": 4} for name in ds.data_vars if ds[name].dtype.kind in "fiu"}
    with atomic_path(path, overwrite) as tmp:
        ds.to_netcdf(tmp, engine="netcdf4", format="NETCDF4", encoding=encoding)


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


def speed_profile(ds: xr.Dataset) -> np.ndarray | None:
    """The speed over time (m/s) of a validated ensemble: None when it is the constant ``v_c`` (or
    a ``v`` that never changes), else ``v`` over time (its mean over runs for (sample, time))."""
    if "v" not in ds:
        return None
    v = ds["v"].values
    v = v.mean(axis=0) if v.ndim == 2 else v
    return None if np.all(v == v[0]) else v


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
            raise DataError(f"{source}: missing variable '{name}' ({unit})")
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
        with xr.open_dataset(path, engine="netcdf4", decode_times=False, decode_timedelta=False) as ds:
            ds = ds.load()
    except Exception as exc:  # netCDF4/HDF5 raise many kinds; any of them means an unreadable file
        reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise DataError(f"'{path}' is not a readable netCDF file ({reason}); write it with xarray's to_netcdf") from exc
    return validate_ensemble(ds, str(path))

"""Files at the edge of uqdrive: atomic writes (no half-written output survives a failure), CSV
tables from lists of rows, and validation of ensembles in the shared data schema (dims, units,
NaN) with messages that name the fix.
"""

from __future__ import annotations

import csv
import os
import tempfile
from contextlib import contextmanager
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np
import xarray as xr

from .vehicle.single_track import STATE_UNITS

__all__ = ["DataError", "OutputError", "check_writable", "atomic_path", "write_csv_rows", "write_dataset", "read_ensemble", "validate_ensemble"]


class DataError(ValueError):
    """A data file does not follow the uqdrive ensemble schema."""


class OutputError(OSError):
    """An output path cannot be written."""


def check_writable(path: str | Path) -> Path:
    """Fail early, before any work, if ``path`` cannot be created in its folder."""
    path = Path(path)
    parent = path.parent if str(path.parent) else Path(".")
    if path.is_dir():
        raise OutputError(f"output path '{path}' is a directory; give a file name")
    if not parent.is_dir():
        raise OutputError(f"output folder '{parent}' does not exist; create it first")
    if not os.access(parent, os.W_OK):
        raise OutputError(f"output folder '{parent}' is not writable")
    return path


@contextmanager
def atomic_path(path: str | Path):
    """Yield a temporary path beside ``path``; rename it onto ``path`` only if the block succeeds."""
    path = check_writable(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)  # mkstemp creates 0600; give the file the usual mode
    try:
        yield Path(tmp)
        os.replace(tmp, path)
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


def write_dataset(ds: xr.Dataset, path: str | Path) -> None:
    """Write a dataset as netCDF4 (zlib-compressed variables) atomically."""
    encoding = {name: {"zlib": True, "complevel": 4} for name in ds.data_vars if ds[name].dtype.kind in "fiu"}
    with atomic_path(path) as tmp:
        ds.to_netcdf(tmp, engine="netcdf4", format="NETCDF4", encoding=encoding)


def validate_ensemble(ds: xr.Dataset, source: str = "dataset") -> xr.Dataset:
    """Check an ensemble against the uqdrive schema; raise :class:`DataError` naming the fix.

    Required: dims ``sample`` and ``time``; a uniform, increasing ``time`` coordinate in s;
    variables psi, psi_dot, beta, y of dims (sample, time) with their SI ``units``; no NaN;
    a ``delta`` (time) variable in rad; a global attribute ``v_c`` (m/s).
    """
    for dim in ("sample", "time"):
        if dim not in ds.dims:
            raise DataError(f"{source}: missing dimension '{dim}'; ensembles have dims (sample, time)")
    if "time" not in ds.coords:
        raise DataError(f"{source}: missing coordinate 'time' (seconds)")
    t = ds["time"].values.astype(float)
    if ds["time"].attrs.get("units", "s") != "s":
        raise DataError(f"{source}: coordinate 'time' has units '{ds['time'].attrs['units']}'; convert to 's'")
    steps = np.diff(t)
    if t.size < 2 or np.any(steps <= 0) or not np.allclose(steps, steps[0], rtol=1e-6, atol=1e-12):
        raise DataError(f"{source}: 'time' must be a uniform, increasing grid; resample the data onto one")
    required = dict(STATE_UNITS, delta="rad")
    for name, unit in required.items():
        if name not in ds:
            raise DataError(f"{source}: missing variable '{name}' ({unit})")
        want = ("time",) if name == "delta" else ("sample", "time")
        if ds[name].dims != want:
            raise DataError(f"{source}: variable '{name}' has dims {ds[name].dims}; expected {want}")
        got = ds[name].attrs.get("units")
        if got != unit:
            raise DataError(f"{source}: variable '{name}' has units '{got}'; expected '{unit}' (convert it and set the attribute)")
        n_nan = int(np.isnan(ds[name].values).sum())
        if n_nan:
            raise DataError(f"{source}: variable '{name}' holds {n_nan} NaN values; remove or interpolate those samples")
    if "v_c" not in ds.attrs:
        raise DataError(f"{source}: missing global attribute 'v_c' (vehicle speed in m/s)")
    return ds


def read_ensemble(path: str | Path) -> xr.Dataset:
    """Open and validate an ensemble file (loaded into memory, file closed)."""
    path = Path(path)
    if not path.is_file():
        raise DataError(f"ensemble file '{path}' does not exist")
    try:
        with xr.open_dataset(path, engine="netcdf4") as ds:
            ds = ds.load()
    except (OSError, ValueError) as exc:
        raise DataError(f"'{path}' is not a readable netCDF file: {exc}") from exc
    return validate_ensemble(ds, str(path))

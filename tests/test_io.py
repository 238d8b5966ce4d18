import numpy as np
import pytest
import xarray as xr

from uqdrive.io import DataError, OutputError, atomic_path, read_ensemble, validate_ensemble, write_dataset
from uqdrive.vehicle.montecarlo import simulate_ensemble
from uqdrive.settings import Settings


@pytest.fixture(scope="module")
def ensemble(config):
    return simulate_ensemble(Settings.from_config(config), "lst", samples=4)


def test_roundtrip_keeps_schema_and_values(ensemble, tmp_path):
    path = tmp_path / "e.nc"
    write_dataset(ensemble, path)
    back = read_ensemble(path)
    np.testing.assert_array_equal(back["y"].values, ensemble["y"].values)
    assert back.attrs["config_hash"] == ensemble.attrs["config_hash"]
    assert [p.name for p in tmp_path.iterdir()] == ["e.nc"]


def test_failed_write_leaves_no_file(tmp_path):
    path = tmp_path / "out.txt"
    with pytest.raises(RuntimeError):
        with atomic_path(path) as tmp:
            tmp.write_text("half")
            raise RuntimeError("boom")
    assert list(tmp_path.iterdir()) == []


def test_unwritable_destinations(tmp_path):
    with pytest.raises(OutputError, match="does not exist"):
        write_dataset(xr.Dataset(), tmp_path / "missing" / "x.nc")
    with pytest.raises(OutputError, match="directory"):
        write_dataset(xr.Dataset(), tmp_path)


def _without_attr(ds, name):
    ds = ds.copy()
    ds.attrs = {k: v for k, v in ds.attrs.items() if k != name}
    return ds


@pytest.mark.parametrize(
    "corrupt, message",
    [
        (lambda d: d.drop_vars(["psi", "psi_dot", "beta", "y", "a_y"], errors="ignore"), "no usable channel"),
        (lambda d: d.rename({"sample": "run"}), "missing dimension 'sample'"),
        (lambda d: d.assign(psi=d["psi"].assign_attrs(units="deg")), "units 'deg'; expected 'rad'"),
        (lambda d: d.assign(y=d["y"].where(d["time"] < 5)), "NaN"),
        (lambda d: d.assign_coords(time=d["time"].values ** 2), "uniform"),
        (lambda d: _without_attr(d, "v_c"), "v_c"),
    ],
)
def test_validation_names_the_problem(ensemble, corrupt, message):
    bad = corrupt(ensemble.copy())
    with pytest.raises(DataError, match=message):
        validate_ensemble(bad)


def test_read_missing_or_garbage(tmp_path):
    with pytest.raises(DataError, match="does not exist"):
        read_ensemble(tmp_path / "none.nc")
    junk = tmp_path / "junk.nc"
    junk.write_text("not netcdf")
    with pytest.raises(DataError, match="not a readable netCDF"):
        read_ensemble(junk)


@pytest.mark.parametrize(
    "corrupt, message",
    [
        (lambda d: d.assign(y=d["y"].where(d["time"] < 5, np.inf)), "'y' holds .* infinite values"),
        (lambda d: d.assign(beta=d["beta"] * 1e6), "'beta' reaches .* beyond the physical"),
        (lambda d: d.assign(psi=d["psi"].astype("int32")), r"'psi' has dtype int32; store it as floating point"),
        (lambda d: d.assign_attrs(v_c=-1.0), "'v_c' = -1 m/s is outside the physical range 0.5-100 m/s"),
        (lambda d: d.assign_attrs(v_c=float("nan")), "'v_c' = nan m/s"),
        (lambda d: d.assign_attrs(v_c="70 km/h"), "'v_c' is '70 km/h'; give one number"),
        (lambda d: d.assign_attrs(v_c=np.array([1.0, 2.0])), "'v_c' is array"),
        (lambda d: d.assign_attrs(v_c=True), "'v_c' is True"),
        (lambda d: d.isel(time=[0, 1]), "at least 3"),
        (lambda d: d.assign(psi_dot=d["psi_dot"] * 0), "'psi_dot' is zero everywhere"),
        (lambda d: d.assign(y=d["y"].isel(sample=0).broadcast_like(d["y"]).copy()), "'y' is identical in every realisation"),
        (lambda d: d.assign_coords(time=d["time"].astype("timedelta64[s]")), "coordinate 'time' has dtype"),
        (lambda d: d.assign(spun=("sample", np.full(d.sizes["sample"], 2))), "'spun' must be one 0/1 flag"),
    ],
)
def test_validation_refuses_non_physical_values(ensemble, corrupt, message):
    with pytest.raises(DataError, match=message):
        validate_ensemble(corrupt(ensemble.copy(deep=True)))


def test_valid_float32_and_integer_v_c_pass(ensemble):
    ds = ensemble.copy(deep=True).assign(psi=ensemble["psi"].astype("float32")).assign_attrs(v_c=20)
    validate_ensemble(ds)


def test_atomic_path_without_overwrite_refuses_an_existing_file(tmp_path):
    path = tmp_path / "x.txt"
    path.write_text("old")
    with pytest.raises(OutputError, match="exists; pass --force"):
        with atomic_path(path, overwrite=False) as tmp:
            tmp.write_text("new")
    assert path.read_text() == "old" and [p.name for p in tmp_path.iterdir()] == ["x.txt"]
    with atomic_path(path) as tmp:
        tmp.write_text("new")
    assert path.read_text() == "new"

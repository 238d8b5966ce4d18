"""`uqdrive import`: recorded runs (MDF4 written by asammdf, CSV in both dialects) of an independent
simulator come back as the ensemble that simulator gives directly; every bad input is refused."""

from __future__ import annotations

import hashlib
import json
import math
import re
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
import yaml

sys.path.insert(0, str(Path(__file__).parent))
import recorded_runs as rr  # noqa: E402

from uqdrive.cli.main import main  # noqa: E402
from uqdrive.io import DataError, read_ensemble  # noqa: E402
from uqdrive.recordings.channel_map import read_channel_map, unit_factor  # noqa: E402
from uqdrive.recordings.importer import import_runs  # noqa: E402
from uqdrive.recordings.resample import continuous_channel  # noqa: E402

pytest.importorskip("asammdf")

V = 25.0  # m/s, 90 km/h: the understeer term K v^2 is 40 % of the wheelbase, so mu shows in the response
SUFFIXES = (".mf4", ".csv", ".de.csv")


def _write_map(folder: Path, **changes) -> Path:
    spec = {k: dict(v) for k, v in rr.MAP.items()}
    for key, value in changes.items():
        if value is None:
            spec.pop(key)
        else:
            spec[key] = value
    path = folder / "map.yaml"
    path.write_text(yaml.safe_dump(spec), encoding="utf-8")
    return path


@pytest.fixture(scope="module")
def twelve(tmp_path_factory):
    """Twelve runs, mu ~ N(1, 0.1), each starting 0.5-2 s before its manoeuvre, as MDF4, English
    and German CSV in turn."""
    folder = tmp_path_factory.mktemp("runs")
    rng = np.random.default_rng(3)
    mus, leads = rng.normal(1.0, 0.1, 12), rng.uniform(0.5, 2.0, 12)
    runs = rr.record(mus, V, leads)
    files = [rr.write(r, folder / f"run{i:02d}{SUFFIXES[i % 3]}") for i, r in enumerate(runs)]
    return folder, files, mus, leads


def _cli(argv, capsys):
    code = main([str(a) for a in argv])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


# -- units and readers ------------------------------------------------------------------------------
def test_units_are_converted_by_dimension_and_a_wrong_dimension_is_refused():
    assert unit_factor("km/h", "m/s") == pytest.approx(1 / 3.6, rel=1e-15)
    assert unit_factor("g", "m/s^2") == pytest.approx(9.80665, rel=1e-15)  # standard gravity, not the gram
    assert unit_factor("deg/s", "rad/s") == pytest.approx(math.pi / 180, rel=1e-15)
    assert unit_factor("ms", "s") == pytest.approx(1e-3, rel=1e-15)
    assert unit_factor("mph", "m/s") == pytest.approx(0.44704, rel=1e-12)
    for bad in ("deg/s", "kg", "not_a_unit"):
        with pytest.raises(ValueError):
            unit_factor(bad, "m/s^2")
    with pytest.raises(DataError, match=r"entry 'a_y' \(channel 'LatAcc'\).*dimension"):
        read_channel_map({**rr.MAP, "a_y": {"channel": "LatAcc", "units": "deg/s"}})


def test_the_map_gives_sign_and_steering_ratio_and_the_vehicle_file_gives_the_ratio(tmp_path):
    cmap = read_channel_map(rr.MAP)
    assert cmap.entries["a_y"].factor == pytest.approx(-9.80665)
    assert cmap.entries["delta"].factor == pytest.approx(math.pi / 180 / rr.RATIO)
    car = tmp_path / "car.yaml"
    spec = yaml.safe_load((Path(__file__).parents[1] / "src/uqdrive/vehicles/rajamani_sedan.yaml").read_text())
    car.write_text(yaml.safe_dump({**spec, "steering_ratio": rr.RATIO}))
    no_ratio = {**rr.MAP, "delta": {"channel": "SteeringWheelAngle", "units": "deg"}}
    assert read_channel_map(no_ratio).entries["delta"].factor == pytest.approx(math.pi / 180)  # a road-wheel channel
    assert read_channel_map(no_ratio, car).entries["delta"].factor == pytest.approx(math.pi / 180 / rr.RATIO)
    with pytest.raises(DataError, match="differs from the vehicle file's steering_ratio"):
        read_channel_map({**rr.MAP, "delta": {**rr.MAP["delta"], "steering_ratio": 16.0}}, car)


def test_anti_aliasing_removes_what_the_coarser_grid_cannot_hold():
    """A 1 Hz response with a 15 Hz vibration, logged at 100 Hz, on a 20 Hz grid (Nyquist 10 Hz):
    filtered, the grid holds the 1 Hz signal (the filter's gain at 1 Hz is 1 - 1e-13, at 15 Hz
    below 1e-2); sampled without the filter the vibration folds back to 5 Hz at full amplitude."""
    t = np.arange(0.0, 10.0, 0.01)
    slow, x = np.sin(2 * np.pi * t), np.sin(2 * np.pi * t) + 0.5 * np.sin(2 * np.pi * 15 * t)
    grid = np.arange(1.0, 9.0, 0.05)  # away from the ends, where a zero-phase filter starts up
    assert np.max(np.abs(continuous_channel(t, x, 0.05)(grid) - np.sin(2 * np.pi * grid))) < 0.01
    assert np.max(np.abs(continuous_channel(t, x, 0.01)(grid) - np.sin(2 * np.pi * grid))) > 0.4  # not decimated: kept
    assert np.max(np.abs(continuous_channel(t, slow, 0.05)(grid) - np.sin(2 * np.pi * grid))) < 1e-6


# -- the imported ensemble --------------------------------------------------------------------------
@pytest.mark.parametrize("dt", [None, 0.05])
def test_imported_ensemble_equals_the_directly_simulated_one(twelve, dt):
    """Mixed formats and rates (steering and a_y 100 Hz, yaw rate 50 Hz, speed 20 Hz), hand-wheel
    degrees with a ratio, deg/s, g on a right-pointing axis, km/h, leads of 0.5-2 s.

    Offsets: the least-squares match on a noise-free steering is limited by the spline's
    error, measured 2e-8 s; required below a hundredth of a sample. Channels: the cubic spline's
    error is largest where the steering's second derivative jumps (the end of its 0.5 s ramp,
    jump 0.54 rad/s^2, 55 m/s^4 in a_y = c_f delta / m + ...): h^2 |jump| / 8 = 7e-4 m/s^2 at
    h = 0.01 s, 2e-4 of a_y's 3.7 m/s^2 peak (measured 3e-5); on the 0.05 s grid the anti-aliasing
    filter smooths that kink too (measured 3e-4 of the peak). Required: 1e-3 of each peak.
    """
    _, files, mus, leads = twelve
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        ds = import_runs(files, rr.MAP, dt=dt)
    # the 50 Hz yaw rate is interpolated onto the 100 Hz grid (not onto the 20 Hz one): said so
    assert [str(w.message).split(" are ")[0] for w in caught] == (["channel(s) YawRate (0.02 s)"] if dt is None else [])
    step = 0.01 if dt is None else dt
    assert ds.attrs["import_dt"] == pytest.approx(step)
    assert np.max(np.abs(ds["offset"].values - (leads - leads[0]))) < 0.01 * step
    tau = ds["time"].values - leads.min()  # the output starts where the latest-starting run starts
    assert ds["time"].values[0] == 0.0 and tau[0] < 0  # straight driving first
    yaw_rate, a_y = rr.simulate(mus, V)
    for name, truth in (("psi_dot", yaw_rate(tau)), ("a_y", a_y(tau))):
        peak = np.max(np.abs(truth))
        assert np.max(np.abs(ds[name].values - truth)) < 1e-3 * peak, name
    assert np.max(np.abs(ds["delta"].values - rr.steering(tau))) < 1e-3 * rr.STEER_AMPLITUDE
    assert ds.attrs["v_c"] == pytest.approx(V, rel=1e-9) and "v" not in ds
    assert json.loads(ds.attrs["import_steer_flagged"]) == []
    # the span every run shares: from the latest start to the earliest end (the 20 Hz speed's last sample)
    shared = rr.RECORD - 1 / rr.RATES["VehicleSpeed"] - (leads.max() - leads.min())
    assert shared - step < ds["time"].values[-1] <= shared + 1e-9


@pytest.mark.filterwarnings("ignore:channel\\(s\\) YawRate")
def test_without_alignment_the_runs_do_not_match(twelve):
    """The alignment is what makes the ensemble right: taken as recorded, the runs are 1.5 s apart."""
    _, files, mus, leads = twelve
    ds = import_runs(files, rr.MAP, align="none")
    assert np.all(ds["offset"].values == 0.0)
    yaw_rate, _ = rr.simulate(mus, V)
    truth = yaw_rate(ds["time"].values - leads.min())
    assert np.max(np.abs(ds["psi_dot"].values - truth)) > 0.3 * np.max(np.abs(truth))


def test_the_cli_writes_the_ensemble_with_its_provenance(twelve, tmp_path, capsys):
    folder, files, _, leads = twelve
    out = tmp_path / "ensemble.nc"
    code, stdout, stderr = _cli(["import", *files, "--channels", _write_map(tmp_path), "--out", out], capsys)
    assert code == 0, stderr
    assert f"wrote {out}: 12 runs" in stdout and stdout.count("(kept)") == 12
    ds = read_ensemble(out)
    assert list(ds["source_file"].values) == [str(f) for f in files]
    assert list(ds["source_sha256"].values) == [hashlib.sha256(f.read_bytes()).hexdigest() for f in files]
    assert json.loads(ds.attrs["import_channel_map"])["a_y"]["sign"] == -1
    offsets = json.loads(ds.attrs["import_offsets"])
    assert offsets[str(files[5])] == pytest.approx(leads[5] - leads[0], abs=1e-4)
    code, _, stderr = _cli(["import", *files, "--channels", _write_map(tmp_path), "--out", out], capsys)
    assert code == 2 and "exists; pass --force" in stderr


def test_a_driver_run_is_reported_and_dropped_only_when_asked(tmp_path, capsys):
    """Eleven robot runs with 1 % sensor noise and one steered 15 % harder: only that one deviates."""
    rng = np.random.default_rng(5)
    leads = rng.uniform(0.5, 2.0, 12)
    runs = rr.record(rng.normal(1.0, 0.1, 12), V, leads, rng=rng, noise=0.01, scale=np.r_[np.ones(11), 1.15])
    files = [rr.write_mdf(r, tmp_path / f"run{i:02d}.mf4") for i, r in enumerate(runs)]
    cmap = _write_map(tmp_path)
    code, stdout, stderr = _cli(["import", *files, "--channels", cmap, "--out", tmp_path / "all.nc"], capsys)
    assert code == 0 and stdout.count("(deviates)") == 1 and f"{files[-1]}: offset" in stdout
    assert "steer differently" in stderr and str(files[-1]) in stderr
    with xr.open_dataset(tmp_path / "all.nc") as ds:
        deviation = json.loads(ds.attrs["import_steer_deviation"])
        offset_error = np.abs(ds["offset"].values - (leads - leads[0]))
    # with noise the match is limited by it: sigma_o ~ sigma / (|s'| sqrt(N)), measured below 1e-4 s
    assert offset_error.max() < 0.1 * 0.01  # a tenth of a sample, the driver's run included
    assert deviation[str(files[-1])] == pytest.approx(0.15, abs=0.02)  # (1.15 - 1) of the median's RMS
    code, stdout, _ = _cli(["import", *files, "--channels", cmap, "--out", tmp_path / "kept.nc", "--max-steer-deviation",
                            "0.05"], capsys)
    assert code == 0 and stdout.count("(dropped)") == 1
    with xr.open_dataset(tmp_path / "kept.nc") as kept:
        assert kept.sizes["sample"] == 11 and str(files[-1]) not in list(kept["source_file"].values)


@pytest.mark.filterwarnings("ignore:channel\\(s\\) YawRate")
def test_speeds_that_differ_between_runs_are_kept_per_run(tmp_path):
    rng = np.random.default_rng(2)
    runs = rr.record(np.full(6, 1.0), 25.0, rng.uniform(0.5, 2, 6)) + rr.record(np.full(6, 1.0), 25.5, rng.uniform(0.5, 2, 6))
    files = [rr.write_mdf(r, tmp_path / f"run{i:02d}.mf4") for i, r in enumerate(runs)]
    ds = import_runs(files, rr.MAP)
    assert ds["v"].dims == ("sample", "time") and ds["v"].attrs["units"] == "m/s"
    np.testing.assert_allclose(ds["v"].values[:, 0], [25.0] * 6 + [25.5] * 6, rtol=1e-12)


# -- refusals: one line naming the file, the channel and the fix; exit 2; nothing written ------------
def _spoil(run: rr.Run, channel: str, how: str) -> rr.Run:
    t, x = (a.copy() for a in run.channels[channel])
    if how == "gap":
        keep = np.r_[0:300, 330:t.size]
        t, x = t[keep], x[keep]
    elif how == "nan":  # 0.2 s without a value: longer than the import bridges
        x[200:220] = np.nan
    elif how == "backwards":
        t[[100, 101]] = t[[101, 100]]
    run.channels[channel] = (t, x)
    return run


@pytest.mark.parametrize("case, suffix, pattern", [
    ("missing channel", ".mf4", r"channel 'YawRate' \(mapped to psi_dot\) is not in the file; fix the name"),
    ("missing channel", ".de.csv", r"channel 'YawRate' \(mapped to psi_dot\) is not in the header"),
    ("wrong dimension", ".csv", r"entry 'a_y' \(channel 'LatAcc'\): unit 'deg/s' has the dimension"),
    ("ends early", ".mf4", r"channel 'SteeringWheelAngle' ends .* s before the manoeuvre's steering does"),
    ("starts late", ".csv", r"channel 'SteeringWheelAngle' starts .* s after the manoeuvre's steering begins"),
    ("reference starts late", ".mf4", r"run00.mf4: channel 'SteeringWheelAngle' starts 0 s after the manoeuvre's steering"),
    ("gap", ".mf4", r"channel 'YawRate' has a gap of 0.62 s at t = 5.98 s"),
    ("nan", ".de.csv", r"channel 'LatAcc' holds 20 NaN or infinite value\(s\) from t = 1.99 s to 2.2 s, longer than the "
                       r"0.05 s the import bridges"),
    ("backwards", ".mf4", r"channel 'VehicleSpeed' has a time that does not increase at sample 101"),
    ("backwards", ".csv", r"channel 'Zeit_ms' \(the time\) does not increase at data row 101 \(1 s then 0.99 s\)"),
    ("too few runs", ".mf4", r"5 run\(s\).*needs at least 10.*record more runs"),
    ("no steering", ".csv", r"run00.csv: channel 'SteeringWheelAngle' \(the steering\) never moves.*--align none"),
    ("file says another unit", ".mf4", r"run00.mf4: channel 'YawRate' \(mapped to psi_dot\) is recorded in 'deg/s' as the file "
                                       r"says, the map says 'rad/s'; write units: deg/s in the map"),
    ("wrong scale", ".csv", r"variable 'a_y' reaches .* \(channel 'LatAcc' in km/s\^2, map .*: check its units"),
])
def test_bad_input_is_refused_naming_file_and_channel(tmp_path, capsys, case, suffix, pattern):
    rng = np.random.default_rng(11)
    n = 5 if case == "too few runs" else 10
    leads = rng.uniform(0.5, 2.0, n)
    spoiled = 0 if case in ("reference starts late", "no steering") else 3
    if case.endswith("starts late"):
        leads[spoiled] = -0.5
    runs = rr.record(np.full(n, 1.0), V, leads, scale=0.0 if case == "no steering" else 1.0)
    if case == "ends early":
        runs[3] = rr.record(1.0, V, leads[3], duration=5.0)[0]
    if case in ("gap", "nan") or (case == "backwards" and suffix == ".mf4"):
        runs[3] = _spoil(runs[3], {"gap": "YawRate", "nan": "LatAcc", "backwards": "VehicleSpeed"}[case], case)
    if case == "missing channel":
        runs[3].channels["Yaw_Rate"] = runs[3].channels.pop("YawRate")
    files = [rr.write(r, tmp_path / f"run{i:02d}{suffix}") for i, r in enumerate(runs)]
    if case == "backwards" and suffix == ".csv":  # rows out of order: every channel of the row moves with its time
        lines = files[3].read_text().splitlines()
        lines[100], lines[101] = lines[101], lines[100]
        files[3].write_text("\n".join(lines) + "\n")
    changes = {"wrong dimension": {"a_y": {"channel": "LatAcc", "units": "deg/s"}},
               "wrong scale": {"a_y": {"channel": "LatAcc", "units": "km/s^2"}},
               "file says another unit": {"psi_dot": {"channel": "YawRate", "units": "rad/s"}}}.get(case, {})
    cmap = _write_map(tmp_path, **changes)
    out = tmp_path / "ensemble.nc"
    code, stdout, stderr = _cli(["import", *files, "--channels", cmap, "--out", out], capsys)
    assert code == 2 and stdout == ""
    assert len(stderr.strip().splitlines()) == 1, stderr
    assert re.search(pattern, stderr), stderr
    if case not in ("wrong dimension", "too few runs", "wrong scale", "file says another unit"):
        assert str(files[spoiled]) in stderr
    assert not out.exists() and not list(tmp_path.glob(".ensemble.nc*"))


# -- end to end: recorded runs in, the friction distribution out -----------------------------------
@pytest.mark.parametrize("suffixes", [(".mf4",), (".csv", ".de.csv")], ids=["mdf4", "csv"])
def test_import_then_identify_recovers_the_runs_friction(tmp_path, capsys, suffixes):
    """40 runs of the sedan (its vehicle file) at 90 km/h, mu ~ N(1.0, 0.15), 1 % sensor noise on
    every channel, each its own file: `uqdrive import` then `uqdrive identify` lands within 0.06
    of the 40 drawn values' own mean and std (measured: 7e-4 and 3e-3 off) and passes the misfit
    test. The grid is the yaw rate's 50 Hz (a noisy channel interpolated onto a finer grid hides
    its noise from identify's noise estimate: the misfit test then fails at 3.6 times the noise).
    The car is known (l_f its file's, no wind: declared known in the config), m_load 0."""
    rng = np.random.default_rng(7)
    mus = rng.normal(1.0, 0.15, 40)
    runs = rr.record(mus, V, rng.uniform(0.5, 2.0, 40), rng=rng, noise=0.01)
    files = [rr.write(r, tmp_path / f"run{i:02d}{suffixes[i % len(suffixes)]}") for i, r in enumerate(runs)]
    code, _, stderr = _cli(["import", *files, "--channels", _write_map(tmp_path), "--dt", "0.02", "--out",
                            tmp_path / "runs.nc"], capsys)
    assert code == 0, stderr
    config = yaml.safe_load((Path(__file__).parents[1] / "config" / "config.yaml").read_text())
    config["uncertainty"]["l_f"]["std"] = 0.0
    config["uncertainty"]["F_w_mean"] = {"low": 0.0, "high": 0.0}
    (tmp_path / "known.yaml").write_text(yaml.safe_dump(config))
    code, _, stderr = _cli(["identify", tmp_path / "runs.nc", "--config", tmp_path / "known.yaml", "--vehicle",
                            "rajamani_sedan", "--m-load", "0", "--out", tmp_path / "fit"], capsys)
    assert code == 0, stderr
    estimate = json.loads((tmp_path / "fit" / "estimate.json").read_text())
    assert estimate["converged"], estimate["warnings"]
    assert abs(estimate["mu"][0] - mus.mean()) < 0.06
    assert abs(estimate["mu"][1] - mus.std(ddof=1)) < 0.06


def test_the_vehicle_files_steering_ratio_converts_the_hand_wheel(twelve, tmp_path, capsys):
    """A map without steering_ratio and --vehicle with one give the ensemble of the map with it;
    without either the hand-wheel angle is taken for the road wheel's (15.3 times too large)."""
    _, files, _, _ = twelve
    spec = yaml.safe_load((Path(__file__).parents[1] / "src/uqdrive/vehicles/rajamani_sedan.yaml").read_text())
    (tmp_path / "car.yaml").write_text(yaml.safe_dump({**spec, "steering_ratio": rr.RATIO}))
    cmap = _write_map(tmp_path, delta={"channel": "SteeringWheelAngle", "units": "deg"})
    for name, extra in (("car.nc", ["--vehicle", tmp_path / "car.yaml"]), ("none.nc", [])):
        code, _, stderr = _cli(["import", *files, "--channels", cmap, "--dt", "0.02", "--out", tmp_path / name, *extra], capsys)
        assert code == 0, stderr
    reference = import_runs(files, rr.MAP, dt=0.02)
    with xr.open_dataset(tmp_path / "car.nc") as car, xr.open_dataset(tmp_path / "none.nc") as none:
        np.testing.assert_allclose(car["delta"].values, reference["delta"].values, rtol=1e-12, atol=1e-15)
        np.testing.assert_allclose(none["delta"].values, rr.RATIO * reference["delta"].values, rtol=1e-9, atol=1e-12)


def test_the_speed_is_one_number_a_shared_profile_or_one_per_run():
    from uqdrive.recordings.importer import _speed

    ramp = np.linspace(20.0, 25.0, 50)
    assert _speed(np.full((3, 50), 25.0)) == (None, 25.0)
    dims, values = _speed(np.tile(ramp, (3, 1)))[0]
    assert dims == ("time",) and np.allclose(values, ramp, rtol=1e-15, atol=0)
    dims, values = _speed(np.stack([ramp, ramp, ramp * 1.01]))[0]
    assert dims == ("sample", "time") and values.shape == (3, 50)

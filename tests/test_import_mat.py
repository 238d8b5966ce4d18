"""`uqdrive import` of MATLAB .mat recordings: dSPACE recorder files, Simulink's structure with
time, exported timeseries, vectors beside a time vector; v5 (scipy) and v7.3 (HDF5) files."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

sys.path.insert(0, str(Path(__file__).parent))
import recorded_runs as rr  # noqa: E402
from test_import_logs import reference, runs  # noqa: E402,F401  (the fixtures: ten runs and their MDF4 import)

from uqdrive.io import DataError  # noqa: E402
from uqdrive.recordings.importer import import_runs  # noqa: E402
from uqdrive.recordings.mat_log import find_signal, mat_signals, read_mat_tree  # noqa: E402
from uqdrive.recordings.readers import read_recording  # noqa: E402
from uqdrive.recordings.channel_map import read_channel_map  # noqa: E402

pytest.importorskip("asammdf")
pytestmark = pytest.mark.filterwarnings("ignore:channel\\(s\\) YawRate")

V = 25.0
# the files state their units (rr.UNITS), so the map gives none: a unit read wrongly moves the numbers
NO_UNITS = {k: {kk: vv for kk, vv in v.items() if kk != "units"} for k, v in rr.MAP.items() if k != "time"}


def simulink(run: rr.Run, path: Path, version: str) -> Path:
    """Simulink's structure with time, one per sample rate; each signal labelled and in its block's units."""
    axes, index = rr.time_axes(run)
    variables = {}
    for k, t in enumerate(axes):
        signals = [{"values": x.reshape(-1, 1), "label": name, "blockName": f"car/{name}", "unit": rr.UNITS[name]}
                   for name, (_, x) in run.channels.items() if index[name] == k]
        variables[f"rate{k + 1}"] = {"time": t.reshape(-1, 1), "signals": rr.mat_records(signals)}
    return rr.save_mat(path, variables, version)


def timeseries(run: rr.Run, path: Path, version: str) -> Path:
    """Each channel a struct of its own time, data and units (a timeseries exported field by field)."""
    log = {name: {"Time": t.reshape(-1, 1), "Data": x.reshape(-1, 1), "Units": rr.UNITS[name]} for name, (t, x) in run.channels.items()}
    return rr.save_mat(path, {"log": log}, version)


LAYOUTS = {"dspace": rr.write_dspace, "simulink": simulink, "timeseries": timeseries}


@pytest.mark.parametrize("layout,version", [("dspace", "5"), ("dspace", "7.3"), ("simulink", "5"), ("timeseries", "7.3")])
def test_matlab_recordings_give_the_ensemble_of_the_same_runs_in_mdf(runs, reference, tmp_path, layout, version):
    files = [LAYOUTS[layout](r, tmp_path / f"run{i:02d}.mat", version) for i, r in enumerate(runs)]
    ds = import_runs(files, NO_UNITS)
    # the same doubles on the same clocks, resampled and aligned by the same code: the same numbers
    for name in ("psi_dot", "a_y", "delta", "offset"):
        np.testing.assert_array_equal(ds[name].values, reference[name].values, err_msg=name)
    assert ds.attrs["v_c"] == reference.attrs["v_c"] == pytest.approx(V, rel=1e-12)
    assert "deg/s" in ds.attrs["import_units"]


def test_vectors_beside_the_files_time_vector(tmp_path):
    """Every channel at one rate beside a time vector in ms (flat variables, and a struct's fields)."""
    lead = np.array([0.7, 1.3])
    runs = rr.record(np.array([1.0, 0.9]), V, lead)
    t = runs[0].channels["SteeringWheelAngle"][0]
    even = {name: np.interp(t, *run.channels[name]) for run in runs[:1] for name in run.channels}
    mdf_run = rr.Run(runs[0].lead, runs[0].mu, V, {name: (t, x) for name, x in even.items()})
    reference = read_recording(rr.write_mdf(mdf_run, tmp_path / "a.mf4"), read_channel_map(rr.MAP))
    flat = rr.save_mat(tmp_path / "flat.mat", {"Zeit_ms": (t * 1e3).reshape(-1, 1), **{n: x.reshape(-1, 1) for n, x in even.items()}}, "5")
    nested = rr.save_mat(tmp_path / "nested.mat", {"data": {"Zeit_ms": t * 1e3, **even}}, "5")
    for path in (flat, nested):
        got = read_recording(path, read_channel_map(rr.MAP))
        for name, (t_ref, x_ref) in reference.channels.items():
            np.testing.assert_allclose(got.channels[name][0], t_ref, rtol=0, atol=1e-12, err_msg=f"{path.name} {name}")
            np.testing.assert_array_equal(got.channels[name][1], x_ref, err_msg=f"{path.name} {name}")
    # without the map's time entry a vector named time is the default; ms named in the map are not seconds
    seconds = rr.save_mat(tmp_path / "seconds.mat", {"time": t, **even}, "5")
    got = read_recording(seconds, read_channel_map(NO_UNITS))
    np.testing.assert_allclose(got.channels["psi_dot"][0], t - t[0], rtol=0, atol=1e-12)


def test_each_rates_time_vector_named_in_its_entry(runs, reference, tmp_path):
    """Vectors at their own rates beside a time vector each (a logger's export per raster), the map
    naming each entry's time; a time in ms read in the map's time unit."""
    axes, index = rr.time_axes(runs[0])
    files = []
    for i, run in enumerate(runs):
        variables = {name: x for name, (_, x) in run.channels.items()}
        variables.update({f"t_{k + 1}": (run.channels[next(n for n in index if index[n] == k)][0] * 1e3) for k in range(len(axes))})
        files.append(rr.save_mat(tmp_path / f"run{i:02d}.mat", variables, "5"))
    cmap = {name: {**entry, "time": f"t_{index[entry['channel']] + 1}"} for name, entry in rr.MAP.items() if name != "time"}
    ds = import_runs(files, {**cmap, "time": {"channel": "t_1", "units": "ms"}})
    for name in ("psi_dot", "a_y", "delta"):
        np.testing.assert_allclose(ds[name].values, reference[name].values, rtol=0, atol=1e-12 * float(np.abs(reference[name]).max()),
                                   err_msg=name)
    assert '"time": "t_2"' in ds.attrs["import_channel_map"]
    # without the entries' times the 50 Hz yaw rate cannot take the 100 Hz time vector
    with pytest.raises(DataError, match=r"'YawRate' has 600 samples, the time 't_1' 1200; give its entry the time vector "
                                        r"recorded with it \(psi_dot: \{channel: YawRate, time: NAME\}\)"):
        import_runs(files, {**rr.MAP, "time": {"channel": "t_1", "units": "ms"}})
    with pytest.raises(DataError, match=r"the map gives channel 'YawRate' the time 't_2', which only MATLAB files use"):
        read_recording(rr.write_mdf(runs[0], tmp_path / "a.mf4"), read_channel_map(cmap))
    with pytest.raises(DataError, match=r"entry 'psi_dot': time is 3; give the name"):
        read_channel_map({**rr.MAP, "psi_dot": {"channel": "YawRate", "time": 3}})
    with pytest.raises(DataError, match=r"entry 'time': a time entry has no time of its own"):
        read_channel_map({**rr.MAP, "time": {"channel": "t_1", "time": "t_2"}})


def _tree() -> dict:
    t = np.arange(0.0, 1.0, 0.01)
    rec = {"X": {"Name": "t", "Data": t}, "Y": [{"Name": 'Root/"YawRate"/Out1', "Data": np.sin(t), "Unit": "deg/s"},
                                                {"Name": "Root/Chassis/LatAcc", "Data": np.cos(t), "Unit": "g"}]}
    return {"rec": rec, "wide": np.stack([t, 2 * t, 3 * t], axis=1), "data": {"speed": np.full(t.size, 20.0), "t": t},
            "other": {"speed": np.full(t.size, 21.0)}, "time": t}


@pytest.mark.parametrize("channel,path", [
    ('Root/"YawRate"/Out1', "rec.Y(1)"), ("YawRate", "rec.Y(1)"), ("yawrate", "rec.Y(1)"), ("LatAcc", "rec.Y(2)"),
    ("rec.Y(2)", "rec.Y(2)"), ("wide(:,3)", "wide(:,3)"), ("data.speed", "data.speed"), ("other.speed", "other.speed"),
])
def test_a_signal_is_found_by_its_path_or_the_name_it_carries(channel, path):
    signal = find_signal(mat_signals(_tree()), channel, "f.mat", "mapped to x")
    assert signal.path == path
    if path.startswith("rec."):
        assert signal.time is not None and signal.unit in ("deg/s", "g")
    if path == "wide(:,3)":
        np.testing.assert_array_equal(signal.values, 3 * _tree()["time"])


def test_a_name_two_signals_carry_or_none_does_is_refused_naming_where_they_lie():
    signals = mat_signals(_tree())
    with pytest.raises(DataError, match=r"'speed' \(mapped to v\) names 2 signals \(data.speed, other.speed\)"):
        find_signal(signals, "speed", "f.mat", "mapped to v")
    with pytest.raises(DataError, match=r"'Gier' \(mapped to psi_dot\) is not in the file \(it holds rec.Y\(1\), rec.Y\(2\), wide"):
        find_signal(signals, "Gier", "f.mat", "mapped to psi_dot")


def test_bad_mat_files_are_refused_in_one_line(tmp_path):
    cmap = read_channel_map(NO_UNITS)
    t = np.arange(0.0, 2.0, 0.01)
    channels = {"SteeringWheelAngle": t, "YawRate": t, "LatAcc": t, "VehicleSpeed": 90 + t}
    cases = {
        "notime": ({**channels}, r"'YawRate' has no time axis of its own .* \(time: \{channel: NAME, units: s\}\)"),
        "short": ({"time": t[:-5], **channels}, r"'YawRate' has 200 samples, the time 'time' 195"),
        "missing": ({"time": t, "YawRate": t}, r"'LatAcc' \(mapped to a_y\) is not in the file \(it holds time, YawRate\)"),
    }
    for name, (variables, pattern) in cases.items():
        with pytest.raises(DataError, match=pattern):
            read_recording(rr.save_mat(tmp_path / f"{name}.mat", variables, "5"), cmap)
    garbage = tmp_path / "garbage.mat"
    garbage.write_bytes(b"MATLAB 5.0 MAT-file" + bytes(200))
    with pytest.raises(DataError, match="garbage.mat: not a readable MAT file"):
        read_recording(garbage, cmap)
    hdf = tmp_path / "broken73.mat"
    hdf.write_bytes(b"MATLAB 7.3 MAT-file" + bytes(600))
    with pytest.raises(DataError, match="broken73.mat: not a readable MAT file"):
        read_recording(hdf, cmap)


def test_read_mat_tree_gives_v73_files_as_scipy_gives_v5(tmp_path):
    t = np.arange(0.0, 0.05, 0.01)
    variables = {"s": {"Y": rr.mat_records([{"Name": "a", "Data": t.reshape(1, -1)}, {"Name": "bb", "Data": 2 * t[:3].reshape(1, -1)}])},
                 "v": t.reshape(-1, 1), "label": "deg/s"}
    five = read_mat_tree(rr.save_mat(tmp_path / "v5.mat", variables, "5"))
    seven = read_mat_tree(rr.save_mat(tmp_path / "v73.mat", variables, "7.3"))
    for tree in (five, seven):
        assert tree["label"] == "deg/s"
        np.testing.assert_array_equal(tree["v"], t)
        assert [y["Name"] for y in tree["s"]["Y"]] == ["a", "bb"]
        np.testing.assert_array_equal(tree["s"]["Y"][1]["Data"], 2 * t[:3])


_KEYS = st.sampled_from(["time", "Time", "t", "data", "Data", "values", "signals", "X", "Y", "Name", "label", "Unit",
                         "XIndex", "Raster", "YawRate", "speed"])
_LEAVES = st.one_of(
    st.text(max_size=8), st.floats(allow_nan=True), st.integers(-3, 5),
    st.lists(st.floats(allow_nan=True, allow_infinity=True), max_size=6).map(np.array),
    st.sampled_from([np.zeros((0,)), np.zeros((3, 4)), np.zeros((1, 1)), np.ones((2, 2, 2)), np.array([1 + 2j, 3j]),
                     np.array(["a", "b"]), np.arange(5), np.array(True)]),
)
_TREES = st.recursive(_LEAVES, lambda inner: st.one_of(st.lists(inner, max_size=4), st.dictionaries(_KEYS, inner, max_size=5)),
                      max_leaves=20)


@given(tree=st.dictionaries(_KEYS, _TREES, max_size=4), channel=_KEYS)
@settings(max_examples=300, deadline=None)
def test_any_tree_of_variables_gives_signals_or_a_one_line_refusal(tree, channel):
    """Whatever a file's variables hold (structs lacking fields, odd shapes, text where numbers
    belong), the search returns float vectors with a time of their length or refuses with DataError."""
    for signal in mat_signals(tree):
        assert signal.values.ndim == 1 and signal.values.dtype == float
        assert signal.time is None or signal.time.shape == (signal.time.size,)
    try:
        found = find_signal(mat_signals(tree), channel, "f.mat", "mapped to x")
    except DataError as exc:
        assert "\n" not in str(exc)
    else:
        assert channel.casefold() in (n.casefold() for n in found.names)

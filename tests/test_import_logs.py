"""`uqdrive import` of logs as loggers write them: the units a file states (used where the map gives
none, checked where it does), CSV dialects (tab, decimal comma, Windows-1252, a preamble, units in
the header or a row below it, clock and date times) and absolute clocks."""

from __future__ import annotations

import functools
import json
import math
import random
import sys
import tempfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

sys.path.insert(0, str(Path(__file__).parent))
import recorded_runs as rr  # noqa: E402

from uqdrive.io import DataError  # noqa: E402
from uqdrive.recordings.channel_map import read_channel_map, recorded_unit_factor, unit_factor  # noqa: E402
from uqdrive.recordings.csv_log import CsvLog, clock_seconds, split_unit  # noqa: E402
from uqdrive.recordings.importer import import_runs  # noqa: E402
from uqdrive.recordings.readers import read_recording  # noqa: E402

pytest.importorskip("asammdf")
pytestmark = pytest.mark.filterwarnings("ignore:channel\\(s\\) YawRate")

V = 25.0
LABELS = {"SteeringWheelAngle": "\u00b0", "YawRate": "\u00b0/s", "LatAcc": "g", "VehicleSpeed": "km/h"}
NO_UNITS = {k: {kk: vv for kk, vv in v.items() if kk != "units"} for k, v in rr.MAP.items() if k != "time"}
# CSV files written with "%.10g": they differ from the MDF files' doubles in the 11th digit.
CSV_DIGITS = 1e-9


@pytest.fixture(scope="module")
def runs():
    rng = np.random.default_rng(21)
    return rr.record(rng.normal(1.0, 0.1, 10), V, rng.uniform(0.5, 2.0, 10))


@pytest.fixture(scope="module")
def reference(runs, tmp_path_factory):
    folder = tmp_path_factory.mktemp("reference")
    return import_runs([rr.write_mdf(r, folder / f"run{i:02d}.mf4") for i, r in enumerate(runs)], rr.MAP)


def _mdf(run: rr.Run, path: Path, labels: dict, clock: float = 0.0) -> Path:
    from asammdf import MDF, Signal

    mdf = MDF(version="4.10")
    for name, (t, x) in run.channels.items():
        mdf.append([Signal(np.asarray(x, float), t + clock, name=name, unit=labels.get(name, ""))])
    mdf.save(path, overwrite=True)
    mdf.close()
    return path


def _assert_same(ds, reference, atol):
    for name in ("psi_dot", "a_y", "delta"):
        np.testing.assert_allclose(ds[name].values, reference[name].values, rtol=0, atol=atol * np.abs(reference[name]).max(),
                                   err_msg=name)


# -- the unit a file states -------------------------------------------------------------------------
def test_a_files_unit_label_is_read_when_it_says_something():
    assert recorded_unit_factor("\u00b0/s", "rad/s") == pytest.approx(math.pi / 180, rel=1e-15)
    assert recorded_unit_factor("m/s\u00b2", "m/s^2") == 1.0
    assert recorded_unit_factor("[km/h]", "m/s") == pytest.approx(1 / 3.6, rel=1e-15)
    assert recorded_unit_factor("g", "m/s^2") == pytest.approx(9.80665, rel=1e-15)
    assert recorded_unit_factor("\u00b0", "rad") == pytest.approx(math.pi / 180, rel=1e-15)
    assert recorded_unit_factor("1/s", "rad/s") == 1.0
    for silent in ("", "-", "1", "%", "Grad", "n.a.", "counts"):
        assert recorded_unit_factor(silent, "rad") is None, silent  # dimensionless labels name no angle
    with pytest.raises(ValueError, match="dimension"):
        recorded_unit_factor("km/h", "rad/s")


def test_the_map_refuses_an_ambiguous_or_unreadable_unit_in_one_line():
    with pytest.raises(ValueError, match="ambiguous"):
        unit_factor("Grad", "rad")  # pint reads giga-radian
    with pytest.raises(ValueError, match="not a unit"):
        unit_factor("-", "rad")  # pint's parser fails with an AssertionError here
    with pytest.raises(DataError, match=r"entry 'delta'.*'Grad' is ambiguous.*write deg or gon"):
        read_channel_map({**rr.MAP, "delta": {"channel": "SteeringWheelAngle", "units": "Grad"}})
    with pytest.raises(DataError, match="check_units is 'no'; give true"):
        read_channel_map({**rr.MAP, "v": {"channel": "VehicleSpeed", "check_units": "no"}})


def test_an_mdf_files_units_serve_a_map_without_units(runs, reference, tmp_path):
    """MDF4 carries each channel's unit: a map that gives none takes the file's (deg, deg/s, g,
    km/h): the same ensemble as the map that gives them. Read as SI instead, the yaw rate would be
    57 times too large."""
    files = [_mdf(r, tmp_path / f"run{i:02d}.mf4", LABELS) for i, r in enumerate(runs)]
    ds = import_runs(files, NO_UNITS)
    _assert_same(ds, reference, 1e-12)
    units = json.loads(ds.attrs["import_units"])[str(files[0])]
    assert units == {"psi_dot": "\u00b0/s", "a_y": "g", "delta": "\u00b0", "v": "km/h"}


def test_an_mdf_unit_that_disagrees_with_the_map_is_refused_unless_the_map_says_so(runs, reference, tmp_path):
    files = [_mdf(r, tmp_path / f"run{i:02d}.mf4", LABELS) for i, r in enumerate(runs)]
    wrong = {**rr.MAP, "psi_dot": {"channel": "YawRate", "units": "rad/s"}}
    with pytest.raises(DataError, match=r"run00.mf4: channel 'YawRate' \(mapped to psi_dot\) is recorded in '\u00b0/s' as the "
                                        r"file says, the map says 'rad/s'; write units: \u00b0/s"):
        import_runs(files, wrong)
    # the user knows better than the label: the map's unit wins
    trusted = import_runs(files, {**wrong, "psi_dot": {**wrong["psi_dot"], "check_units": False}})
    scaled = reference["psi_dot"].values * 180 / math.pi
    np.testing.assert_allclose(trusted["psi_dot"].values, scaled, rtol=0, atol=1e-12 * np.abs(scaled).max())
    # a channel of another quantity mapped by mistake
    other = [_mdf(r, tmp_path / f"o{i:02d}.mf4", {**LABELS, "YawRate": "km/h"}) for i, r in enumerate(runs)]
    with pytest.raises(DataError, match=r"o00.mf4: channel 'YawRate' \(mapped to psi_dot\) is recorded in 'km/h', no unit of "
                                        r"psi_dot \(rad/s\); map psi_dot to the channel that records it"):
        import_runs(other, rr.MAP)


def test_labels_that_say_nothing_leave_the_maps_unit(runs, reference, tmp_path):
    files = [_mdf(r, tmp_path / f"run{i:02d}.mf4", {"SteeringWheelAngle": "-", "YawRate": "1", "LatAcc": "%"})
             for i, r in enumerate(runs)]
    _assert_same(import_runs(files, rr.MAP), reference, 1e-12)


# -- CSV as loggers write it ------------------------------------------------------------------------
def _csv(run: rr.Run, path: Path, kind: str, start: float = 0.0) -> Path:
    """The English CSV of recorded_runs, rewritten as another logger writes it."""
    rr.write_csv(run, path)
    lines = path.read_text().splitlines()
    names = list(run.channels)
    rows = [line.split(",") for line in lines[1:]]
    header = ["Zeit_ms", *names]
    if kind == "german_tab":  # tab, decimal comma, a units row with degree signs, Windows-1252, CRLF
        text = "\r\n".join(["\t".join(header), "\t".join(["[ms]", *(f"[{LABELS[n]}]" for n in names)]),
                            *("\t".join(c.replace(".", ",") for c in r) for r in rows)]) + "\r\n"
        path.write_bytes(text.encode("cp1252"))
        return path
    if kind == "preamble_brackets":  # device lines before a header that carries the units
        header = ["Zeit_ms [ms]", *(f"{n} [{LABELS[n]}]" for n in names)]
        lines = ["Logger: XL-4 export", "Date;2026-11-29", "", ",".join(header), *(",".join(r) for r in rows)]
    elif kind == "epoch_ms":  # an absolute clock: ms since 1970
        lines = [",".join(header), *(",".join([f"{float(r[0]) + start * 1e3:.3f}", *r[1:]]) for r in rows)]
    elif kind == "iso":
        t0 = np.datetime64("2026-11-29T23:59:58.5")
        lines = [",".join(["Zeit_ms", *names]),
                 *(",".join([str(t0 + np.timedelta64(round(float(r[0]) * 1e3), "us")).replace("T", " "), *r[1:]]) for r in rows)]
    elif kind == "clock":
        def hms(ms):
            s = 10 * 3600 + 59 * 60 + 58.5 + ms / 1e3
            return f"{int(s // 3600):02d}:{int(s % 3600 // 60):02d}:{s % 60:06.3f}"
        lines = [",".join(["Zeit_ms", *names]), *(",".join([hms(float(r[0])), *r[1:]]) for r in rows)]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


@pytest.mark.parametrize("kind, cmap", [("german_tab", NO_UNITS | {"time": {"channel": "Zeit_ms"}}),
                                        ("preamble_brackets", NO_UNITS | {"time": {"channel": "Zeit_ms"}}),
                                        ("epoch_ms", rr.MAP), ("iso", rr.MAP), ("clock", rr.MAP)])
def test_csv_exports_of_other_loggers_give_the_same_ensemble(runs, reference, tmp_path, kind, cmap):
    """Units from the file (a units row, or brackets in the header) where the map gives none; date
    and clock times (seconds from the first row; the map's ms does not apply to them). Tolerance:
    the CSV's ten digits; the absolute clock keeps 1e-7 s of its ms (a double near 1.8e12 resolves
    2.4e-4 ms), well inside it."""
    files = [_csv(r, tmp_path / f"run{i:02d}.csv", kind, 1.8e9 + 60.0 * i) for i, r in enumerate(runs)]
    ds = import_runs(files, cmap)
    _assert_same(ds, reference, CSV_DIGITS)
    np.testing.assert_allclose(ds["offset"].values, reference["offset"].values + (60.0 * np.arange(10) if kind == "epoch_ms"
                                                                                  else 0.0), rtol=0, atol=1e-4)


def test_a_csv_unit_that_disagrees_with_the_map_is_refused(runs, tmp_path):
    files = [_csv(r, tmp_path / f"run{i:02d}.csv", "preamble_brackets") for i, r in enumerate(runs)]
    with pytest.raises(DataError, match=r"run00.csv: channel 'LatAcc' \(mapped to a_y\) is recorded in 'g'.*the map says "
                                        r"'m/s\^2'"):
        import_runs(files, {**rr.MAP, "a_y": {"channel": "LatAcc", "units": "m/s^2", "sign": -1}})


def test_header_cells_and_times_are_read_as_loggers_write_them():
    assert split_unit("YawRate [deg/s]") == ("YawRate", "deg/s")
    assert split_unit("Zeit (s)") == ("Zeit", "s")
    assert split_unit("YawRate") == ("YawRate", "")
    assert split_unit("[deg]") == ("[deg]", "")  # a bracket alone is no name
    log = CsvLog(["Time [s]", "YawRate", "yawrate"], ["s", "", ""], [], ".")
    assert log.column("time") == 0 and log.column("YawRate") == 1 and log.column("yawrate") == 2
    assert log.column("YAWRATE") is None  # two columns differ from it only in case: neither is taken
    np.testing.assert_allclose(clock_seconds(["23:59:59.5", "23:59:59,75"]), [0.0, 0.25])
    np.testing.assert_allclose(clock_seconds(["2026-11-29 23:59:59.5", "2026-11-30T00:00:00.25"]), [0.0, 0.75])
    assert clock_seconds(["0.5", "1.0"]) is None and clock_seconds(["12:00", "12:01"]) is None


# -- what loggers lose ------------------------------------------------------------------------------
def _lose(run: rr.Run, how: str) -> rr.Run:
    channels = dict(run.channels)
    t, x = (a.copy() for a in channels["LatAcc"])
    if how == "lost frames":  # four 100 Hz frames dropped mid-manoeuvre: a 0.05 s step
        keep = np.r_[0:450, 454:t.size]
        t, x = t[keep], x[keep]
    elif how == "invalid values":  # one invalid sample mid-manoeuvre, none before the sensor's first value
        x[450] = np.nan
        x[:5] = np.nan
    elif how == "long gap":
        keep = np.r_[0:450, 456:t.size]
        t, x = t[keep], x[keep]
    channels["LatAcc"] = (t, x)
    return rr.Run(run.lead, run.mu, run.v, channels)


@pytest.mark.parametrize("how", ["lost frames", "invalid values"])
def test_lost_frames_and_invalid_values_are_bridged(runs, reference, tmp_path, how):
    """The spline bridges up to MAX_BRIDGED_GAP: on this manoeuvre's a_y (content below 1.2 Hz,
    peak 3.7 m/s^2) the cubic across 0.05 s is off by about (2 pi 1.2 0.05)^4 / 384 = 3e-5 of
    the peak (measured 1.8e-5); required 1e-3. Invalid values at a channel's start shorten the span."""
    files = [rr.write_mdf(_lose(r, how), tmp_path / f"run{i:02d}.mf4") for i, r in enumerate(runs)]
    ds = import_runs(files, rr.MAP)
    # five invalid leading values: every run's a_y starts 0.05 s later, and so does the shared span
    late = 5 if how == "invalid values" else 0
    assert ds.sizes["time"] == reference.sizes["time"] - late
    expected = reference["a_y"].values[:, late:]
    np.testing.assert_allclose(ds["a_y"].values, expected, rtol=0, atol=1e-3 * np.abs(expected).max())
    assert np.max(np.abs(ds["a_y"].values - expected)) > 1e-9  # the loss was read, and bridged


def test_a_gap_longer_than_the_bridge_is_refused(runs, tmp_path):
    files = [rr.write_mdf(_lose(r, "long gap"), tmp_path / f"run{i:02d}.mf4") for i, r in enumerate(runs)]
    with pytest.raises(DataError, match=r"run00.mf4: channel 'LatAcc' has a gap of 0.07 s at t = 4.49 s \(its period is 0.01 s; "
                                        r"the import bridges up to 0.05 s\)"):
        import_runs(files, rr.MAP)


# -- damaged exports ---------------------------------------------------------------------------------
_DAMAGE = ("drop a cell", "append text", "swap two rows", "cut the file", "blank line", "header again", "random text",
           "semicolons", "open quote", "empty column", "nan", "minus", "row twice", "one cell", "extra cells")


def _damage(lines: list, rng: random.Random) -> list:
    lines = list(lines)
    for _ in range(rng.randint(1, 4)):
        if not lines:
            break
        how, i = rng.choice(_DAMAGE), rng.randrange(len(lines))
        if how == "drop a cell":
            cells = lines[i].split(",")
            cells.pop(rng.randrange(len(cells)))
            lines[i] = ",".join(cells)
        elif how == "append text":
            lines[i] += rng.choice(["abc", ",,,", '"', "1e999", "--", "\u00b0"])
        elif how == "swap two rows":
            j = rng.randrange(len(lines))
            lines[i], lines[j] = lines[j], lines[i]
        elif how == "cut the file":
            lines = lines[: rng.randint(0, len(lines))]
        elif how == "blank line":
            lines.insert(i, "")
        elif how == "header again":
            lines.insert(i, lines[0])
        elif how == "random text":
            lines[i] = "".join(chr(rng.randint(32, 0x2FF)) for _ in range(rng.randint(0, 30)))
        elif how == "semicolons":
            lines[i] = lines[i].replace(",", ";")
        elif how == "open quote":
            lines[i] = '"' + lines[i]
        elif how == "empty column":
            lines = [line + "," for line in lines]
        elif how == "nan":
            lines[i] = lines[i].replace("0", "nan", 1)
        elif how == "minus":
            lines[i] = "-" + lines[i]
        elif how == "row twice":
            lines.insert(i, lines[i])
        elif how == "one cell":
            lines[i] = lines[i].split(",")[0]
        else:
            lines[i] += ",1,2,3"
    return lines


@functools.lru_cache(maxsize=1)
def _clean_lines() -> list:
    """The lines of one run's English CSV export (recorded once)."""
    with tempfile.TemporaryDirectory() as folder:
        return rr.write_csv(rr.record(1.0, V, 1.0)[0], Path(folder) / "clean.csv").read_text().splitlines()


@settings(max_examples=50, deadline=None, database=None, derandomize=True)
@given(st.integers(0, 2**32 - 1))
def test_a_damaged_csv_export_is_refused_or_read_whole(tmp_path_factory, seed):
    """Cells dropped or added, rows swapped, repeated or cut, text where numbers belong, stray quotes
    and delimiters: the reader refuses with a DataError or returns channels with finite values on
    increasing times, never another exception."""
    folder = tmp_path_factory.mktemp("damaged", numbered=True)
    path = folder / "run.csv"
    path.write_text("\n".join(_damage(_clean_lines(), random.Random(seed))) + "\n", encoding="utf-8")
    try:
        recording = read_recording(path, read_channel_map(rr.MAP))
    except DataError:
        return
    for t, x in recording.channels.values():
        assert np.all(np.isfinite(t)) and np.all(np.isfinite(x)) and np.all(np.diff(t) > 0)


@pytest.mark.parametrize("rows", [[], ["ms,deg,deg/s,g,km/h"]], ids=["header alone", "header and units"])
def test_a_csv_export_without_data_rows_is_refused(tmp_path, rows):
    path = tmp_path / "run.csv"
    path.write_text("\n".join(["Zeit_ms,SteeringWheelAngle,YawRate,LatAcc,VehicleSpeed", *rows, ""]) + "\n", encoding="utf-8")
    with pytest.raises(DataError, match=r"run.csv: no data rows below the header"):
        read_recording(path, read_channel_map(rr.MAP))

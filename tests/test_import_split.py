"""`uqdrive import --split`: a logger left running through a session records the runs one after
another; they are cut apart where the steering rests, a turn-around between them is left out, and
the ensemble is the one the runs give."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

sys.path.insert(0, str(Path(__file__).parent))
import recorded_runs as rr  # noqa: E402

from uqdrive.cli.main import main  # noqa: E402
from uqdrive.io import DataError  # noqa: E402
from uqdrive.recordings.importer import import_runs  # noqa: E402
from uqdrive.recordings.split import manoeuvres, steering_activity  # noqa: E402

pytest.importorskip("asammdf")
pytestmark = pytest.mark.filterwarnings("ignore:channel\\(s\\) YawRate")

V = 25.0
TURN = 10.0  # s of a turn-around block: the steering held for about 8 s


def _turn_around() -> dict:
    """A block in which the driver turns the car around: 90 degrees at the hand wheel for ~8 s."""
    channels = {}
    for name, rate in rr.RATES.items():
        t = np.arange(0.0, TURN - 1e-9, 1.0 / rate)
        hold = np.clip(np.minimum(t - 1.0, TURN - 1.0 - t) / 0.5, 0.0, 1.0)
        values = {"SteeringWheelAngle": 90.0 * hold, "YawRate": 20.0 * hold, "LatAcc": -0.3 * hold,
                  "VehicleSpeed": np.full(t.size, 30.0)}[name]
        channels[name] = (t, values)
    return channels


def _session(runs: list, path: Path, turn_after: int | None = None) -> tuple[Path, list]:
    """The runs (and a turn-around after run ``turn_after``) one after another in one MDF4 file;
    returns the file and each run's manoeuvre start on the file's clock."""
    blocks, starts, clock = [], [], 0.0
    for i, run in enumerate(runs):
        blocks.append((clock, run.channels))
        starts.append(clock + run.lead)
        clock += rr.RECORD
        if i == turn_after:
            blocks.append((clock, _turn_around()))
            clock += TURN
    joined = {name: (np.concatenate([t0 + ch[name][0] for t0, ch in blocks]), np.concatenate([ch[name][1] for _, ch in blocks]))
              for name in rr.RATES}
    return rr.write_mdf(rr.Run(0.0, 1.0, V, joined), path), starts


@pytest.fixture(scope="module")
def sessions(tmp_path_factory):
    """Twelve runs (mu ~ N(1, 0.1), leads 0.5-2 s) in two session files, a turn-around in the first."""
    folder = tmp_path_factory.mktemp("sessions")
    rng = np.random.default_rng(4)
    mus, leads = rng.normal(1.0, 0.1, 12), rng.uniform(0.5, 2.0, 12)
    runs = rr.record(mus, V, leads)
    first, starts_1 = _session(runs[:6], folder / "morning.mf4", turn_after=2)
    second, starts_2 = _session(runs[6:], folder / "afternoon.mf4")
    return [first, second], mus, starts_1 + starts_2


def test_the_manoeuvres_are_found_where_the_steering_leaves_its_rest():
    t = np.arange(0.0, 30.0, 0.01)
    delta = np.where((t > 5) & (t < 9), np.sin(2 * np.pi * (t - 5) / 2.0), 0.0) + np.where((t > 20) & (t < 22), 0.5, 0.0)
    found = manoeuvres(t, delta, rest=1.0)
    assert len(found) == 2  # the sine's zero crossings (0.02 s below the threshold) lie inside the first
    assert found[0][0] == pytest.approx(5.0, abs=0.02) and found[0][1] == pytest.approx(9.0, abs=0.02)
    assert found[1] == pytest.approx((20.01, 21.99), abs=0.02)
    assert len(manoeuvres(t, delta, rest=0.001)) > 2  # a rest shorter than a zero crossing cuts the sine apart
    noisy = delta + 1e-3 * np.random.default_rng(0).standard_normal(t.size)
    assert not steering_activity(noisy)[t < 4.5].any()  # noise at rest is not a manoeuvre
    # steps held for most of the session, on a sensor whose zero is a little off: the rest is still straight ahead
    steps = 0.003 + np.where((t % 10.0) < 7.0, 0.1, 0.0)
    np.testing.assert_array_equal(steering_activity(steps), (t % 10.0) < 7.0)


def test_split_sessions_give_the_runs_ensemble(sessions):
    """The twelve runs cut out of two files, the turn-around left out: each run's yaw rate is its
    own, aligned, within the resampling error of the per-file import's test (1e-3 of the peak)."""
    files, mus, starts = sessions
    ds = import_runs(files, rr.MAP, split=2.0)
    split = json.loads(ds.attrs["import_split"])
    assert list(split["skipped"]) == [f"{files[0]}#4"] and "not the manoeuvre" in split["skipped"][f"{files[0]}#4"]
    names = [f"{files[0]}#{i}" for i in (1, 2, 3, 5, 6, 7)] + [f"{files[1]}#{i}" for i in range(1, 7)]
    assert list(ds["source_file"].values) == names
    lead = min(m - split["runs"][name][0] for m, name in zip(starts, names))  # the shortest straight run-up
    yaw_rate, _ = rr.simulate(mus, V)
    truth = yaw_rate(ds["time"].values - lead)
    assert np.max(np.abs(ds["psi_dot"].values - truth)) < 1e-3 * np.max(np.abs(truth))
    # each run's offset on the files' clocks: its manoeuvre's start less the first run's
    np.testing.assert_allclose(ds["offset"].values, np.array(starts) - starts[0], atol=1e-4)


def test_without_a_rest_long_enough_the_runs_stay_joined(sessions):
    files, _, _ = sessions
    with pytest.raises(DataError, match=r"import: [12] run\(s\).*needs at least 10"):
        import_runs(files, rr.MAP, split=8.0)  # longer than any rest between runs (4.5-7.5 s): a file is one run


def test_the_command_line_lists_what_it_left_out(sessions, tmp_path, capsys):
    files, _, _ = sessions
    spec = tmp_path / "map.yaml"
    spec.write_text(yaml.safe_dump(rr.MAP))
    code = main(["import", *map(str, files), "--channels", str(spec), "--split", "2", "--out", str(tmp_path / "day.nc")])
    out = capsys.readouterr().out
    assert code == 0 and f"{files[0]}#4: left out, steers for" in out and "wrote" in out and ": 12 runs" in out


def test_a_file_without_steering_is_refused(tmp_path):
    runs = rr.record(np.full(1, 1.0), V, np.full(1, 1.0), scale=0.0)
    path = rr.write_mdf(runs[0], tmp_path / "parked.mf4")
    with pytest.raises(DataError, match=r"parked.mf4: the steering never leaves its rest.*without --split"):
        import_runs([path], rr.MAP, split=2.0)

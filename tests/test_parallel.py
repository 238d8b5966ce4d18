"""Forked workers for the fits of a search step (uqdrive.inference.parallel): the
results of a loop, in its order, the parent's objects returned as themselves, errors raised where
the loop would raise them, and ``--jobs`` checked at the edge."""

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml

from conftest import tiny_config
from uqdrive.cli.main import main
from uqdrive.inference.parallel import available, fork_map, resolve_jobs

# JAX, once another test of the same pytest worker has imported it, warns at every fork of that
# process (its threads): a warning about the test process, not about uqdrive's workers, which never use JAX.
pytestmark = [pytest.mark.skipif(not available(), reason="worker processes need fork (POSIX)"),
              pytest.mark.filterwarnings("ignore:os.fork\\(\\) was called:RuntimeWarning")]


class Box:
    def __init__(self, value):
        self.value = value


def test_the_results_are_the_loops_in_its_order_and_computed_in_other_processes():
    parent = os.getpid()
    out = fork_map(lambda i: (i * i, os.getpid(), time.sleep(0.05))[:2], list(range(7)), 3)
    assert [v for v, _ in out] == [i * i for i in range(7)]
    assert all(pid != parent for _, pid in out) and len({pid for _, pid in out}) > 1


def test_shared_objects_come_back_as_the_parents_others_as_copies():
    shared, other = Box(1), Box(2)
    out = fork_map(lambda i: (shared, other, Box(i)), [0, 1], 2, shared=[shared])
    assert all(a is shared for a, _, _ in out)
    assert all(b is not other and b.value == 2 for _, b, _ in out)
    assert [c.value for _, _, c in out] == [0, 1]


def test_a_shared_none_does_not_turn_every_none_into_a_reference():
    out = fork_map(lambda i: [None, i], [0, 1], 2, shared=[Box(0)])
    assert out == [[None, 0], [None, 1]]


def test_changes_a_worker_makes_stay_in_the_worker_and_one_job_runs_here():
    seen = []
    fork_map(lambda i: seen.append(i), [0, 1, 2], 2)
    assert seen == []  # each worker appended to its own copy
    fork_map(lambda i: seen.append(i), [0, 1, 2], 1)
    assert seen == [0, 1, 2]


def test_the_first_failing_item_raises_its_exception_here():
    def fn(i):
        if i in (2, 4):
            raise ValueError(f"item {i}")
        return i

    with pytest.raises(ValueError, match="item 2") as raised:
        fork_map(fn, range(6), 2)
    assert "in fn" in raised.value.__notes__[0] and "worker process" in raised.value.__notes__[0]


def test_a_result_that_cannot_be_pickled_is_computed_here():
    parent = os.getpid()
    out = fork_map(lambda i: (lambda: i, os.getpid()), [0, 1], 2)
    assert [f() for f, _ in out] == [0, 1] and all(pid == parent for _, pid in out)


def test_a_map_inside_a_worker_runs_as_a_loop():
    out = fork_map(lambda i: fork_map(lambda j: (j, os.getpid()), [0, 1], 2), [0, 1], 2)
    for inner in out:
        assert len({pid for _, pid in inner}) == 1  # both items in the one worker


def test_a_worker_that_dies_is_an_error_not_a_wait():
    with pytest.raises(RuntimeError, match="ended before their work"):
        fork_map(lambda i: os._exit(3), [0, 1, 2], 2)


@pytest.mark.parametrize("jobs, expected", [(1, 1), (3, 3), ("2", 2), (None, 1)])
def test_job_counts(jobs, expected):
    assert resolve_jobs(jobs) == expected


def test_auto_is_the_cpus_this_process_may_use():
    assert resolve_jobs("auto") == len(os.sched_getaffinity(0)) >= 1


@pytest.mark.parametrize("jobs", [0, -2, 1.5, "many", True])
def test_a_bad_job_count_is_refused_naming_it(jobs):
    with pytest.raises(ValueError, match="positive whole number or 'auto'"):
        resolve_jobs(jobs)


@pytest.mark.parametrize("flag, words", [("0", "below 1"), ("two", "neither a whole number nor 'auto'")])
def test_the_jobs_flag_is_checked_at_the_edge(flag, words, tmp_path, capsys):
    code = main(["discover", str(tmp_path / "runs.nc"), "--out", str(tmp_path / "out"), "--jobs", flag])
    err = capsys.readouterr().err
    assert code == 2 and words in err and len(err.strip().splitlines()) == 1, err
    assert not (tmp_path / "out").exists()


def _children(pid: int) -> list[int]:
    """Processes whose parent is ``pid`` (from /proc)."""
    found = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if int(fields[1]) == pid:
                found.append(int(entry.name))
    return found


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """(config, 60 NLST runs of 3 s): a discover whose search runs for some seconds."""
    root = tmp_path_factory.mktemp("interrupt")
    cfg = tiny_config(t_end=3.0, samples=60)
    (root / "c.yaml").write_text(yaml.safe_dump(cfg))
    assert main(["simulate", "--model", "nlst", "--config", str(root / "c.yaml"), "--out", str(root / "runs.nc")]) == 0
    return root


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs /proc to see the workers")
@pytest.mark.parametrize("signum, group", [(signal.SIGINT, True), (signal.SIGTERM, False)], ids=["ctrl-c", "kill"])
def test_an_interrupted_run_with_workers_exits_cleanly_and_ends_them(runs, tmp_path, signum, group):
    """Ctrl-C (SIGINT to the whole process group, as a terminal sends it) or SIGTERM to the
    command alone while its workers fit: exit 128 + N with the one line, no output folder, and
    no worker left running."""
    out = tmp_path / "gap"
    argv = ["discover", str(runs / "runs.nc"), "--config", str(runs / "c.yaml"), "--candidates", "tyre_saturation,actuator_lag,road_bank",
            "--no-posterior", "--jobs", "2", "--out", str(out)]
    proc = subprocess.Popen([sys.executable, "-c", "import sys; from uqdrive.cli import main; sys.exit(main(sys.argv[1:]))", *argv],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)
    deadline, workers = time.monotonic() + 120, []
    while not workers:
        assert proc.poll() is None and time.monotonic() < deadline, "the run never started its workers"
        workers = _children(proc.pid)
        time.sleep(0.02)
    time.sleep(0.2)
    (os.killpg if group else os.kill)(proc.pid, signum)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 128 + signum, err
    assert err.count("\n") == 1 and f"interrupted by {signal.Signals(signum).name}" in err, err
    assert not out.exists()
    deadline = time.monotonic() + 10
    while any(Path(f"/proc/{w}").exists() for w in workers):
        assert time.monotonic() < deadline, "a worker outlived the run"
        time.sleep(0.05)

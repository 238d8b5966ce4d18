"""One more run of the CI-sized DAG (config/test.yaml) shows three things at once.

* The cluster path: the run starts on snakemake-executor-plugin-cluster-generic with the local
  stand-in for a batch system (workflow/profiles/cluster-generic-local: submit.sh, status.sh,
  cancel.sh), small jobs batched into group jobs.
* Interrupted runs resume with the README's own command, `make reproduce` (its steps read from
  `make -n reproduce`): the cluster run gets Ctrl-C (SIGINT to its process group) part way; make
  reproduce resumes it and is itself killed with kill -9 part way, which leaves a stale lock and
  orphaned jobs; make reproduce again: its stale-lock step names the orphans and the command that
  ends them, then removes the lock, and the run finishes. Nothing that had finished runs again.
* Determinism: the scorecard and every netCDF file's values equal those of the uninterrupted
  first run (the session fixture ``workdir`` of conftest.py), bit for bit, wall-clock timings
  aside.
"""

import importlib.util
import os
import re
import shlex
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
import xarray as xr

from conftest import REPO

# Every test of the DAG runs on one xdist worker, so the session-scoped `workdir` run happens once.
pytestmark = [pytest.mark.xdist_group("dag"), pytest.mark.workflow]

TEST_CONFIG = REPO / "config" / "test.yaml"
CLUSTER_PROFILE = REPO / "workflow" / "profiles" / "cluster-generic-local"
STALE_LOCK = REPO / "workflow" / "profiles" / "default" / "stale_lock.py"
#: Jobs finished before each interruption (of the ~70 jobs of config/test.yaml).
CTRL_C_AFTER, KILL_AFTER = 10, 4
#: Variables and attributes that hold the wall-clock seconds a step took: they measure the
#: machine, not the result, and are the only values a rerun may change.
WALL_CLOCK = {"seconds"}
#: netCDF files whose values may differ in the last bits (path below results/ -> (rtol, why)).
#: Empty: the interrupted, cluster-run and resumed DAG reproduced every value bit for bit.
TOLERANCES: dict[str, tuple[float, str]] = {}

_spec = importlib.util.spec_from_file_location("stale_lock", STALE_LOCK)
stale_lock = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(stale_lock)


def readme_commands():
    """What `make reproduce` (README "The two commands") runs before its report, for
    CONFIG=config/test.yaml CORES=2, as `make -n` prints it: the stale-lock step and Snakemake's
    arguments (paths made absolute, as the commands run in another folder)."""
    out = subprocess.run(["make", "-n", "reproduce", "CONFIG=config/test.yaml", "CORES=2"], cwd=REPO, capture_output=True,
                         text=True, check=True).stdout
    lines = [shlex.split(line) for line in out.splitlines() if line.strip()]
    unlock = next(line for line in lines if line[-1].endswith("stale_lock.py"))
    run = next(line for line in lines if line[0].endswith("bin/snakemake") and "--report" not in line)
    assert REPO / unlock[-1] == STALE_LOCK and run[1:] == ["--cores", "2", "--configfile", "config/test.yaml"]
    args = [str(REPO / a) if (REPO / a).is_file() else a for a in run[1:]]
    return [sys.executable, str(STALE_LOCK)], [sys.executable, "-m", "snakemake", "-s", str(REPO / "Snakefile"), *args]


def _start(cmd, wd, log):
    """Start cmd in wd in a session of its own with Ctrl-C's default meaning (as a terminal runs a
    command), output to log. A test run started in the background (`pytest ... &` in a script,
    nohup) inherits SIGINT ignored, and Python then never turns it into KeyboardInterrupt: the
    Ctrl-C below would be lost (seen in session 9: the cluster run went on to the end)."""
    with open(log, "w") as fh:
        return subprocess.Popen(cmd, cwd=wd, stdout=fh, stderr=subprocess.STDOUT, start_new_session=True,
                                preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))


def _finished(log):
    return log.read_text().count("Finished jobid:")


def _planned(log):
    """Jobs the run set out to do (its "Job stats" total, `all` included)."""
    return int(re.search(r"^total\s+(\d+)", log.read_text(), re.MULTILINE).group(1))


def _wait(condition, proc, log, timeout):
    start = time.monotonic()
    while not condition():
        assert proc.poll() is None, f"{log.name} ended before it could be interrupted:\n{log.read_text()[-3000:]}"
        assert time.monotonic() - start < timeout, f"timeout waiting in {log.name}:\n{log.read_text()[-3000:]}"
        time.sleep(0.5)


def _cut(log):
    """Jobs a run started (Snakemake prints each as it starts it, a group job's all at once) but
    did not finish: the work an interruption throws away."""
    text = log.read_text()
    return len(re.findall(r"^\s*(?:local)?rule \w+:$", text, re.MULTILINE)) - text.count("Finished jobid:")


def _step(log, t0, **more):
    return dict(seconds=time.monotonic() - t0, planned=_planned(log), finished=_finished(log), cut=_cut(log), log=log.read_text(), **more)


def _unlock_as_told(unlock, wd):
    """The stale-lock step of `make reproduce`; when it stops and names processes, end them as its
    line says (kill PID ...) and run it again. Both answers."""
    answers = [subprocess.run(unlock, cwd=wd, capture_output=True, text=True)]
    if answers[0].returncode == 2 and (told := re.search(r"\(kill ([\d ]+)[;)]", answers[0].stderr)):
        pids = [int(p) for p in told.group(1).split()]
        for sig, wait in ((signal.SIGTERM, 30), (signal.SIGKILL, 30)):  # kill, then kill -9 (as the line says)
            for pid in pids:
                try:
                    os.kill(pid, sig)
                except ProcessLookupError:
                    pass
            end = time.monotonic() + wait
            while stale_lock.snakemake_processes(wd.resolve()) and time.monotonic() < end:
                time.sleep(0.5)
            if not stale_lock.snakemake_processes(wd.resolve()):
                break
        answers.append(subprocess.run(unlock, cwd=wd, capture_output=True, text=True))
    return answers


# The second DAG run costs ~3.5-5 CPU-minutes. In CI it took a clean-clone `.ci/run` to 9 min 27 s
# and 9 min 47 s (two runs, session 8, idle 2-core machine), too close to CI's 10 minutes, so it
# runs on demand: `pytest -m slow tests/test_dag_repeatability.py`. (Session 8 also found that CI
# had been running the first DAG twice: pytest 9.2 broke xdist's loadgroup; now pinned.) Session 9:
# CI without it 8 min 19 s on a slower day (the session-8 commit: 9 min 44 s), so still on demand.
SECOND_RUN = pytest.mark.slow


@pytest.fixture(scope="module")
def resumed(tmp_path_factory):
    """The DAG through the cluster executor, Ctrl-C, make reproduce, kill -9, make reproduce: what
    each step did."""
    wd = tmp_path_factory.mktemp("interrupted")
    unlock, readme = readme_commands()
    steps = {}

    # 1. The cluster path; Ctrl-C once CTRL_C_AFTER jobs have finished.
    log, t0 = wd / "cluster.log", time.monotonic()
    proc = _start([sys.executable, "-m", "snakemake", "-s", str(REPO / "Snakefile"), "--configfile", str(TEST_CONFIG),
                   "--workflow-profile", str(CLUSTER_PROFILE)], wd, log)
    # ... and its log has been quiet for a moment: Snakemake waits on running jobs, as when a user
    # presses Ctrl-C during a long job (see the test below for a Ctrl-C while it schedules).
    _wait(lambda: _finished(log) >= CTRL_C_AFTER and time.time() - log.stat().st_mtime > 1.5, proc, log, timeout=900)
    os.killpg(proc.pid, signal.SIGINT)
    steps["cluster"] = _step(log, t0, returncode=proc.wait(timeout=120), locks=sorted((wd / ".snakemake" / "locks").glob("*")))

    # 2. make reproduce; kill -9 once KILL_AFTER jobs have finished and one runs.
    log, t0 = wd / "readme_1.log", time.monotonic()
    steps["unlock_1"] = _unlock_as_told(unlock, wd)
    proc = _start(readme, wd, log)
    _wait(lambda: _finished(log) >= KILL_AFTER and len(stale_lock.snakemake_processes(wd.resolve()) or []) > 1, proc, log, timeout=600)
    proc.kill()
    proc.wait()
    steps["readme_1"] = _step(log, t0, locks=sorted((wd / ".snakemake" / "locks").glob("*")))

    # 3. make reproduce again, to the end.
    log, t0 = wd / "readme_2.log", time.monotonic()
    steps["unlock_2"] = _unlock_as_told(unlock, wd)
    proc = _start(readme, wd, log)
    steps["readme_2"] = _step(log, t0, returncode=proc.wait(timeout=900))
    for name in ("cluster", "readme_1", "readme_2"):
        step = steps[name]
        print(f"{name}: {step['seconds']:.0f} s, {step['finished']} of {step['planned']} planned jobs finished, {step['cut']} cut")
    for name in ("unlock_1", "unlock_2"):
        print(name, [(a.returncode, a.stderr.strip()) for a in steps[name]])
    return wd, steps


@SECOND_RUN
def test_the_dag_runs_through_the_cluster_generic_executor_in_group_jobs(resumed):
    _, steps = resumed
    cluster = steps["cluster"]
    submitted = re.findall(r"Submitted (group job|job) \S+ with external jobid '(\d+)'", cluster["log"])
    assert submitted and all(kind == "group job" for kind, _ in submitted), cluster["log"][-3000:]  # every rule has a group
    assert cluster["finished"] >= CTRL_C_AFTER
    assert cluster["returncode"] != 0
    if "Terminating processes on user request" in cluster["log"]:
        # Ctrl-C while Snakemake waits on jobs: it stops, cancelling the jobs it can (cancel.sh),
        # and removes its lock.
        assert cluster["locks"] == [], cluster["log"][-3000:]
    else:
        # Ctrl-C while Snakemake selects jobs (seen once in CI: "Error grouping resources in group
        # 'bayes': KeyboardInterrupt"): it stops with the interrupt reported and may leave its
        # lock, which make reproduce's stale-lock step removes (the next test checks that it ran).
        assert "KeyboardInterrupt" in cluster["log"], cluster["log"][-3000:]
        if cluster["locks"]:
            assert "removed the stale lock" in steps["unlock_1"][-1].stderr, steps["unlock_1"]


@SECOND_RUN
def test_make_reproduce_resumes_after_ctrl_c_and_kill_9_rerunning_only_what_was_cut(resumed):
    _, steps = resumed
    cluster, first, last = steps["cluster"], steps["readme_1"], steps["readme_2"]
    # The stale-lock step lets make reproduce start: at once, or once the processes it named ended.
    assert steps["unlock_1"][-1].returncode == 0
    # Nothing that had finished runs again: each run plans at most what the previous one left.
    assert first["planned"] <= cluster["planned"] - cluster["finished"]
    assert last["planned"] <= first["planned"] - first["finished"]
    assert first["locks"], "kill -9 leaves the lock that stops the next run (LockException)"
    # After kill -9: the step names the jobs the killed run left behind, with the commands that
    # end them and clear the lock, or (they ended) removes the stale lock; then make reproduce finishes.
    answers = steps["unlock_2"]
    if answers[0].returncode == 2:
        assert "still run in this folder" in answers[0].stderr and "(kill " in answers[0].stderr and "snakemake --unlock" in answers[0].stderr
    assert answers[-1].returncode == 0 and "removed the stale lock" in answers[-1].stderr
    assert last["returncode"] == 0, last["log"][-3000:]
    assert f"{last['finished']} of {last['finished']} steps (100%) done" in last["log"]


def _differences(first, second, rel):
    """Variables, coordinates and attributes of two datasets that differ, wall-clock times aside."""
    rtol = TOLERANCES.get(rel, (0.0, ""))[0]
    out = []
    if set(first.variables) != set(second.variables):
        out.append(f"variables {sorted(set(first.variables) ^ set(second.variables))}")
    for name in sorted((set(first.variables) & set(second.variables)) - WALL_CLOCK):
        a, b = first[name].values, second[name].values
        if a.shape != b.shape:
            out.append(f"{name}: shape {a.shape} != {b.shape}")
        elif a.dtype.kind in "fc":
            if not (np.array_equal(a, b, equal_nan=True) if rtol == 0 else np.allclose(a, b, rtol=rtol, atol=0, equal_nan=True)):
                out.append(f"{name}: max |difference| {np.nanmax(np.abs(a - b)):.3g}")
        elif not np.array_equal(a, b):
            out.append(f"{name}: values differ")
    attrs = [({k: str(v) for k, v in ds.attrs.items() if k not in WALL_CLOCK}) for ds in (first, second)]
    if attrs[0] != attrs[1]:
        out.append(f"attributes {sorted(k for k in attrs[0].keys() | attrs[1].keys() if attrs[0].get(k) != attrs[1].get(k))}")
    return out


@SECOND_RUN
def test_resumed_outputs_equal_the_uninterrupted_run(workdir, resumed):
    wd, _ = resumed
    first, second = workdir / "results", wd / "results"
    assert (second / "scorecard.csv").read_bytes() == (first / "scorecard.csv").read_bytes()
    files = sorted(str(p.relative_to(first)) for p in first.rglob("*.nc"))
    assert files and files == sorted(str(p.relative_to(second)) for p in second.rglob("*.nc"))
    differences = {}
    for rel in files:
        with xr.open_dataset(first / rel, decode_times=False) as a, xr.open_dataset(second / rel, decode_times=False) as b:
            if found := _differences(a, b, rel):
                differences[rel] = found
    assert not differences, differences
    assert set(TOLERANCES) <= set(files)


def test_every_rule_declares_what_a_scheduler_needs():
    """threads, mem_mb and runtime on every rule of workflow/rules (the targets `all` and
    `reported` of the Snakefile run nothing)."""
    missing = []
    for path in sorted((REPO / "workflow" / "rules").glob("*.smk")):
        for name, body in re.findall(r"^rule (\w+):\n((?:[ \t]+.*\n|\n)*)", path.read_text(), re.MULTILINE):
            missing += [f"{path.name}: {name} {key}" for key in ("threads:", "mem_mb=", "runtime=") if key not in body]
    assert not missing


def test_a_cluster_gets_tens_of_jobs_not_hundreds(tmp_path):
    """The default config's DAG, dry run through the cluster profile: its groups make ~20
    submissions of its >100 jobs."""
    proc = subprocess.run([sys.executable, "-m", "snakemake", "-s", str(REPO / "Snakefile"), "--directory", str(tmp_path), "-n",
                           "--configfile", str(REPO / "config" / "config.yaml"), "--workflow-profile", str(CLUSTER_PROFILE)],
                          capture_output=True, text=True)
    out = proc.stdout + proc.stderr
    assert proc.returncode == 0, out[-3000:]
    jobs = int(re.search(r"^total\s+(\d+)", out, re.MULTILINE).group(1))
    submissions = len(re.findall(r"^\[.*\] Group job \w+", out, re.MULTILINE)) + len(re.findall(r"^rule \w+:", out, re.MULTILINE))
    assert jobs > 100 and submissions <= 30, (jobs, submissions)

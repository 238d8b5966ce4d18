"""The second run of the CI-sized DAG (config/test.yaml) and its interruptions, for
tests/test_dag_repeatability.py; conftest.py starts it beside the first run (``workdir``)."""

import importlib.util
import os
import re
import shlex
import signal
import subprocess
import sys
import time

from conftest import REPO

TEST_CONFIG = REPO / "config" / "test.yaml"
CLUSTER_PROFILE = REPO / "workflow" / "profiles" / "cluster-generic-local"
STALE_LOCK = REPO / "workflow" / "profiles" / "default" / "stale_lock.py"
#: Jobs finished before each interruption (of the ~70 jobs of config/test.yaml).
CTRL_C_AFTER, KILL_AFTER = 10, 4

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
    Ctrl-C below would be lost (the cluster run would go on to its end)."""
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


def interrupted_runs(wd):
    """The DAG through the cluster executor, Ctrl-C, make reproduce, kill -9, make reproduce, in
    folder ``wd``: what each step did.

    Part of CI: it costs ~2 CPU-minutes and runs in a thread beside the first run (conftest's
    ``workdir``), so that its waits (the cluster executor's status checks, Snakemake's starts,
    the interruptions) overlap the first run's work; one after the other, the two took CI to
    9.5-9.8 min."""
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
    return steps



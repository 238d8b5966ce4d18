"""The second run of the CI-sized DAG (config/test.yaml) and its interruptions, for
tests/test_dag_repeatability.py and tests/test_slurm.py; conftest.py starts it beside the first
run (``workdir``). Where Slurm answers (CI: tools/slurm_cluster.sh start), the run goes on and
ends on the Slurm cluster through workflow/profiles/slurm."""

import importlib.util
import os
import re
import shlex
import signal
import subprocess
import sys
import shutil
import time

import yaml

from conftest import REPO

TEST_CONFIG = REPO / "config" / "test.yaml"
CLUSTER_PROFILE = REPO / "workflow" / "profiles" / "cluster-generic-local"
SLURM_PROFILE = REPO / "workflow" / "profiles" / "slurm"
SLURM_SCRIPT = "tools/slurm_cluster.sh"
STALE_LOCK = REPO / "workflow" / "profiles" / "default" / "stale_lock.py"
#: Jobs finished before each interruption (of the ~70 jobs of config/test.yaml): kill -9 of make
#: reproduce after KILL_AFTER, Ctrl-C of the Slurm run after CTRL_C_AFTER more.
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
    """Jobs the run set out to do (its "Job stats" total, `all` included; 0 if it printed none)."""
    found = re.search(r"^total\s+(\d+)", log.read_text(), re.MULTILINE)
    return int(found.group(1)) if found else 0


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


def slurm_unreachable():
    """Why Slurm cannot take this suite's jobs (one line), or None when `sinfo` lists a node of the
    default partition that takes jobs."""
    if shutil.which("sinfo") is None:
        return "sinfo is not on PATH"
    try:
        done = subprocess.run(["sinfo", "-h", "-N", "-o", "%T %P"], capture_output=True, text=True, timeout=30)
    except subprocess.TimeoutExpired:
        return "sinfo gave no answer in 30 s"
    if done.returncode != 0:
        return f"sinfo failed: {done.stderr.strip()[:200]}"
    states = [line.split()[0] for line in done.stdout.splitlines() if line.split()[-1].endswith("*")]
    if not any(s.rstrip("*~#!%$@^-") in ("idle", "mixed", "allocated", "completing") for s in states):
        return f"no node of the default partition takes jobs (sinfo: {' '.join(states) or 'none'})"
    return None


def slurm_command():
    """The Slurm run as docs/cluster.md gives it (the profile sizes jobs to the partition's
    nodes), the config being config/test.yaml; the same command resumes a stopped run. Targets
    may follow (the last option takes one value)."""
    return [sys.executable, "-m", "snakemake", "-s", str(REPO / "Snakefile"), "--configfile", str(TEST_CONFIG),
            "--workflow-profile", str(SLURM_PROFILE)]


def slurm_jobids(log_text):
    """Slurm job ids a run submitted (the plugin's "submitted with SLURM jobid N" lines)."""
    return re.findall(r"has been submitted with SLURM jobid (\d+)", log_text)


def _run_uuid(log):
    found = re.search(r"SLURM run ID: (\S+)", log.read_text())
    return found.group(1) if found else None


def _running_slurm_jobs(log, max_age=None):
    """Ids of the run's Slurm jobs that squeue shows running (the run's jobs carry its run ID as
    name); with ``max_age``, only those that started at most that many seconds ago."""
    uuid = _run_uuid(log)
    if uuid is None:
        return []
    out = subprocess.run(["squeue", "-h", "-t", "R", "-n", uuid, "-o", "%i %M"], capture_output=True, text=True).stdout
    jobs = [line.split() for line in out.splitlines() if line.strip()]
    return [jobid for jobid, elapsed in jobs if max_age is None or clock_seconds(elapsed) <= max_age]


def clock_seconds(value):
    """A Slurm duration (squeue's %M, sacct's Elapsed: [D-][HH:]MM:SS[.s]) in seconds."""
    days, _, clock = value.rpartition("-")
    seconds = 0.0
    for part in clock.split(":"):
        seconds = 60 * seconds + float(part)
    return (int(days) if days else 0) * 86400 + seconds


#: An interruption hits a job that started at most this many seconds ago: on a node that runs one
#: group job at a time, the work it throws away (and the suite has to do again) is then seconds.
YOUNG = 5


def _slurm_step(wd, name, steps, interrupt=None):
    """One Slurm run in wd (log NAME.log). interrupt(proc, log) -> what it did, or None to let it run
    to the end. A run that finds the folder locked (a hard stop left the lock) is unlocked with
    `snakemake --unlock` and started again, as docs/cluster.md says."""
    t0 = time.monotonic()
    unlocked = any((wd / ".snakemake" / "locks").glob("*"))  # no run works here: a stale lock
    if unlocked:
        subprocess.run([*slurm_command(), "--unlock"], cwd=wd, capture_output=True, check=True)
    log = wd / f"{name}.log"
    proc = _start(slurm_command(), wd, log)
    did = interrupt(proc, log) if interrupt is not None else None
    steps[name] = _step(log, t0, returncode=proc.wait(timeout=1200), jobids=slurm_jobids(log.read_text()), did=did,
                        unlocked=unlocked, locks=sorted((wd / ".snakemake" / "locks").glob("*")))


def _ctrl_c_while_a_job_runs(proc, log):
    _wait(lambda: _finished(log) >= CTRL_C_AFTER and _running_slurm_jobs(log, YOUNG) and time.time() - log.stat().st_mtime > 1.5,
          proc, log, timeout=900)
    running = _running_slurm_jobs(log)
    os.killpg(proc.pid, signal.SIGINT)
    return running


def _scancel_a_running_job(proc, log):
    _wait(lambda: _running_slurm_jobs(log, YOUNG), proc, log, timeout=900)
    jobid = (_running_slurm_jobs(log, YOUNG) or _running_slurm_jobs(log))[0]
    subprocess.run(["scancel", jobid], check=True)
    return jobid


def interrupted_runs(wd, slurm=False):
    """The second run of the DAG in folder ``wd``, interrupted: what each step did.

    make reproduce, killed with kill -9 part way (a stale lock and orphaned jobs); make reproduce's
    stale-lock step. Then, with ``slurm``: the Slurm run (docs/cluster.md's command), Ctrl-C while
    a job runs; the same command again, one running job cancelled with scancel (the run stops with
    that job's error and Slurm log); the same command again, to the end. Without Slurm: make
    reproduce to the end.

    Part of CI: it runs in a thread beside the first run (conftest's ``workdir``), so
    that its waits (status checks, Snakemake's starts, the interruptions) overlap the first run's
    work. Run one after the other, CI took 9.5-9.8 min."""
    unlock, readme = readme_commands()
    steps = {}

    # 1. make reproduce; kill -9 once KILL_AFTER jobs have finished and one runs.
    log, t0 = wd / "readme_1.log", time.monotonic()
    proc = _start(readme, wd, log)
    _wait(lambda: _finished(log) >= KILL_AFTER and len(stale_lock.snakemake_processes(wd.resolve()) or []) > 1, proc, log, timeout=600)
    proc.kill()
    proc.wait()
    steps["readme_1"] = _step(log, t0, locks=sorted((wd / ".snakemake" / "locks").glob("*")))
    steps["unlock_1"] = _unlock_as_told(unlock, wd)

    if not slurm:
        log, t0 = wd / "readme_2.log", time.monotonic()
        proc = _start(readme, wd, log)
        steps["readme_2"] = _step(log, t0, returncode=proc.wait(timeout=900))
        return steps

    # 2-4. On the Slurm cluster: Ctrl-C, scancel, to the end.
    _slurm_step(wd, "slurm_1", steps, _ctrl_c_while_a_job_runs)
    _slurm_step(wd, "slurm_2", steps, _scancel_a_running_job)
    _slurm_step(wd, "slurm_3", steps)
    return steps


#: Targets of the failing-rule run: the tyre-curve figure (made to fail) and the KLE beside it.
FAILING_RULE_TARGETS = ["results/figures/fig_2_3.png", "results/data/kle.nc"]


def failing_rule_runs(wd):
    """On Slurm, in folder ``wd``: the two targets with a tyre surface named in broken TeX (only
    fig_tyre_curves can fail: matplotlib cannot draw the legend), then with the test config again.
    The failed run, the targets and the rules' logs it left, the rerun (tests/test_slurm.py checks
    them). conftest.py starts this in a thread of its own when the first DAG run starts: its minute
    is mostly Slurm's status checks, which then overlap the suite's work instead of holding an
    xdist worker."""
    config = yaml.safe_load(TEST_CONFIG.read_text())
    config["figures"]["tyre_surfaces"]["Ice $\\undefinedmacro$"] = config["figures"]["tyre_surfaces"].pop("Ice")
    broken = wd / "broken.yaml"
    broken.write_text(yaml.safe_dump(config, sort_keys=False))  # key order: Snakemake compares params as written
    command = slurm_command()
    failed = subprocess.run([str(broken) if a == str(TEST_CONFIG) else a for a in command] + FAILING_RULE_TARGETS, cwd=wd,
                            capture_output=True, text=True, timeout=900)
    made = [target for target in FAILING_RULE_TARGETS if (wd / target).is_file()]
    logs = {str(p.relative_to(wd)): p.read_text() for p in (wd / "results" / "logs").rglob("*.log")}  # the rerun rewrites them
    rerun = subprocess.run([*command, *FAILING_RULE_TARGETS], cwd=wd, capture_output=True, text=True, timeout=900)
    return failed, made, logs, rerun

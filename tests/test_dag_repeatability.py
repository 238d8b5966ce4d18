"""One more run of the CI-sized DAG (config/test.yaml) shows two things at once.

* Interrupted runs resume with the README's own command, `make reproduce` (its steps read from
  `make -n reproduce`): make reproduce is killed with kill -9 part way, which leaves a stale lock
  and orphaned jobs; its stale-lock step names the orphans and the command that ends them, then
  removes the lock. Where Slurm answers, the run goes on on the Slurm cluster (interrupted with
  Ctrl-C and scancel, resumed with docs/cluster.md's command: tests/test_slurm.py), elsewhere with
  make reproduce. Nothing that had finished runs again.
* Determinism: the scorecard and every netCDF file's values equal those of the uninterrupted
  first run (the session fixture ``workdir`` of conftest.py), bit for bit, wall-clock timings
  aside.
"""

import re
import subprocess
import sys

import numpy as np
import pytest
import xarray as xr

from conftest import REPO
from dag_runs import CLUSTER_PROFILE

# Every test of the DAG runs on one xdist worker, so the session-scoped `workdir` run happens once.
pytestmark = [pytest.mark.xdist_group("dag"), pytest.mark.workflow]

#: Variables and attributes that hold the wall-clock seconds a step took: they measure the
#: machine, not the result, and are the only values a rerun may change.
WALL_CLOCK = {"seconds"}
#: netCDF files whose values may differ in the last bits (path below results/ -> (rtol, why)).
#: Empty: the interrupted, cluster-run and resumed DAG reproduced every value bit for bit.
TOLERANCES: dict[str, tuple[float, str]] = {}


@pytest.fixture(scope="module")
def resumed(request, second_run):
    """What each step of the interrupted runs did (conftest's ``second_run``, which the first run
    ``workdir`` starts before it runs, so that the two run side by side)."""
    request.getfixturevalue("workdir")
    wd, _, future = second_run
    steps = future.result()
    for name, step in steps.items():
        if isinstance(step, dict):
            print(f"{name}: {step['seconds']:.0f} s, {step['finished']} of {step['planned']} planned jobs finished, {step['cut']} cut")
        else:
            print(name, [(a.returncode, a.stderr.strip()) for a in step])
    return wd, steps


def _runs(steps):
    """The runs after the kill -9, in order: make reproduce, or the three Slurm runs."""
    return [steps[name] for name in ("readme_2", "slurm_1", "slurm_2", "slurm_3") if name in steps]


def test_make_reproduce_resumes_after_kill_9_and_nothing_finished_runs_again(resumed):
    _, steps = resumed
    first, runs = steps["readme_1"], _runs(steps)
    assert first["locks"], "kill -9 leaves the lock that stops the next run (LockException)"
    # After kill -9: the step names the jobs the killed run left behind, with the commands that
    # end them and clear the lock, or (they ended) removes the stale lock.
    answers = steps["unlock_1"]
    if answers[0].returncode == 2:
        assert "still run in this folder" in answers[0].stderr and "(kill " in answers[0].stderr and "snakemake --unlock" in answers[0].stderr
    assert answers[-1].returncode == 0 and "removed the stale lock" in answers[-1].stderr
    # Nothing that had finished runs again: each run plans at most what the previous one left.
    for before, after in zip([first, *runs], runs):
        assert after["planned"] <= before["planned"] - before["finished"], (before["log"][-2000:], after["log"][-2000:])
    last = runs[-1]
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


def test_resumed_outputs_equal_the_uninterrupted_run(resumed, workdir):
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

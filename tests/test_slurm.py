"""The workflow on a real Slurm cluster through the shipped profile (workflow/profiles/slurm).

CI (.ci/run) starts a one-node cluster with accounting (tools/slurm_cluster.sh start) before the
suite; there these tests fail, never skip, when Slurm cannot be reached. On a machine without
Slurm they skip with one line naming the script that gives one.

* The second run of the CI-sized DAG (tests/dag_runs.py, beside the first run ``workdir``) goes on
  on the cluster after its local kill -9: Ctrl-C while a job runs, the docs' command again and
  scancel of a running job, the docs' command again to the end. tests/test_dag_repeatability.py
  compares its outputs bit for bit with the local run; here: every submission a group job, each
  interruption seen as it should be, sacct listing every job, declared memory and time covering
  what each job used.
* A rule made to fail by a config gives the Slurm log path and the rule's error; the rerun
  submits only what is missing.
* The profile sizes jobs from `sinfo` (fake Slurm commands: runs everywhere).
"""

import importlib.util
import os
import re
import subprocess
import sys
import textwrap

import pytest

from conftest import REPO
from dag_runs import SLURM_PROFILE, SLURM_SCRIPT, clock_seconds, slurm_jobids

pytestmark = pytest.mark.workflow

_spec = importlib.util.spec_from_file_location("rule_resources", REPO / "tools" / "rule_resources.py")
rule_resources = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(rule_resources)
#: Rules of workflow/rules that the CI-sized DAG does not run: the sweep's own, the discovery on
#: measured files and the thesis case's discovery figures, as config/test.yaml lists no measured
#: file and not thesis_nlst among its benchmark cases.
NOT_IN_THE_CI_DAG = {"sweep_config", "sweep_point", "sweep_summary", "discrepancy_measured", "discrepancy_thesis_figures"}


@pytest.fixture(scope="session")
def on_slurm(slurm):
    """Slurm takes jobs: in CI a must, elsewhere a reason to skip."""
    if slurm is not None:
        if os.environ.get("CI") == "true":
            pytest.fail(f"Slurm cannot be reached in CI ({slurm}): .ci/run starts it with {SLURM_SCRIPT} start")
        pytest.skip(f"no Slurm here ({slurm}); `sudo {SLURM_SCRIPT} install && sudo {SLURM_SCRIPT} start` gives a one-node cluster")


def _sacct(jobids, fields, steps=False):
    """sacct rows (dicts) of the given jobs."""
    out = subprocess.run(["sacct", "-n", "-P", *([] if steps else ["-X"]), "-j", ",".join(jobids), "-o", ",".join(fields)],
                         capture_output=True, text=True, check=True).stdout
    return [dict(zip(fields, line.split("|"))) for line in out.splitlines() if line]


def _mb(value):
    """A sacct memory figure (411348K, 4000M, 2G; ReqMem may end in n or c) in MB."""
    if not value:
        return 0.0
    value = value.rstrip("nc")
    scale = {"K": 1 / 1024, "M": 1.0, "G": 1024.0, "T": 1024.0**2}
    return float(value[:-1]) * scale[value[-1]] if value[-1] in scale else float(value) / 2**20


@pytest.fixture(scope="module")
def slurm_runs(request, on_slurm, second_run, tmp_path_factory):
    """The Slurm steps of the second run (conftest's ``second_run``), their wall time reported."""
    request.getfixturevalue("workdir")
    wd, ran_on_slurm, future = second_run
    steps = future.result()
    assert ran_on_slurm and "slurm_3" in steps, "the second run did not reach Slurm"
    runs = {name: steps[name] for name in ("slurm_1", "slurm_2", "slurm_3")}
    line = "Slurm, CI-sized DAG: " + ", ".join(
        f"{name} {step['seconds']:.0f} s ({step['finished']} jobs, {len(step['jobids'])} submissions)" for name, step in runs.items())
    line += f"; {sum(step['seconds'] for step in runs.values()):.0f} s in all"
    print(line)
    (tmp_path_factory.getbasetemp() / "slurm_wall_time.txt").write_text(line + "\n")
    return wd, runs



@pytest.mark.xdist_group("dag")
def test_the_dag_runs_on_slurm_in_group_jobs_through_ctrl_c_and_scancel(slurm_runs):
    wd, runs = slurm_runs
    for step in runs.values():
        logs = re.findall(r"submitted with SLURM jobid \d+ \(log: (\S+)\)", step["log"])
        assert logs and all("/group_" in path for path in logs), step["log"][-3000:]  # every rule has a group
    first = runs["slurm_1"]
    # Ctrl-C while a job runs: Snakemake cancels its jobs (scancel) and stops.
    assert first["did"] and first["returncode"] != 0, first["log"][-3000:]
    assert "KeyboardInterrupt" in first["log"] or "Terminating processes on user request" in first["log"], first["log"][-3000:]
    assert {row["State"].split()[0] for row in _sacct(first["did"], ["JobID", "State"])} == {"CANCELLED"}
    # scancel of a running job: the run stops with that job's state and its Slurm log.
    second = runs["slurm_2"]
    jobid = second["did"]
    assert second["returncode"] != 0
    log = re.search(rf"Error in group \w+\n\s*log: (\S+/{jobid}\.log)", second["log"])
    assert log and (wd / log.group(1)).is_file(), second["log"][-3000:]
    assert runs["slurm_3"]["returncode"] == 0, runs["slurm_3"]["log"][-3000:]


@pytest.mark.xdist_group("dag")
def test_sacct_lists_every_submitted_job_completed_or_cancelled_by_the_interruptions(slurm_runs):
    _, runs = slurm_runs
    states = {}
    for name, step in runs.items():
        rows = _sacct(step["jobids"], ["JobID", "State"])
        states[name] = {row["JobID"]: row["State"].split()[0] for row in rows}
        assert set(states[name]) == set(step["jobids"]), (name, states[name], step["jobids"])
    assert set(states["slurm_3"].values()) == {"COMPLETED"}, states
    for name in ("slurm_1", "slurm_2"):
        assert set(states[name].values()) <= {"COMPLETED", "CANCELLED"}, states
    assert states["slurm_2"][runs["slurm_2"]["did"]] == "CANCELLED"


@pytest.mark.xdist_group("dag")
def test_each_job_used_less_memory_and_time_than_it_declared(slurm_runs):
    """sacct's MaxRSS (batch step plus the largest srun step, sampled every second) and Elapsed of every completed job
    against what it asked for: --mem and -t, from the rules' mem_mb and runtime (a group job asks
    for its members' declarations summed over the jobs that run side by side, largest layer)."""
    _, runs = slurm_runs
    jobids = [j for step in runs.values() for j in step["jobids"]]
    fields = ["JobID", "State", "MaxRSS", "Elapsed", "ReqMem", "Timelimit", "Comment"]
    rows = _sacct(jobids, fields, steps=True)
    jobs = {row["JobID"]: dict(row, batch=0.0, step=0.0) for row in rows if "." not in row["JobID"] and row["State"].startswith("COMPLETED")}
    for row in rows:
        parent, _, step = row["JobID"].partition(".")
        if step and parent in jobs:
            key = "batch" if step == "batch" else "step"
            jobs[parent][key] = max(jobs[parent][key], _mb(row["MaxRSS"]))
    for job in jobs.values():
        # The batch step (the group job's Snakemake) runs beside each srun step (its jobs), one
        # step at a time: the job held at most the two together.
        job["peak"] = job["batch"] + job["step"]
    assert jobs
    table, over = [], []
    for jobid, job in sorted(jobs.items(), key=lambda item: int(item[0])):
        declared_mb, used_s, limit_s = _mb(job["ReqMem"]), clock_seconds(job["Elapsed"]), clock_seconds(job["Timelimit"])
        table.append(f"{jobid:>5} {job['Comment'][:60]:<60} {job['peak']:7.0f} of {declared_mb:6.0f} MB {used_s:5.0f} of {limit_s:5.0f} s")
        if job["peak"] > declared_mb or used_s > limit_s:
            over.append(table[-1])
    print("\n".join(table))
    assert not over, "jobs that used more than they declared (raise mem_mb/runtime of their rules):\n" + "\n".join(over)


@pytest.mark.xdist_group("dag")
def test_each_rule_used_less_memory_and_time_than_it_declared(slurm_runs):
    """Inside a group job sacct sees only the group: each rule's jobs, measured by the benchmark
    files the group job's Snakemake writes (max_rss, wall time), against the rule's mem_mb and
    runtime (tools/rule_resources.py; every rule of the DAG ran, most of them on Slurm)."""
    wd, _ = slurm_runs
    peaks = rule_resources.measured(wd)
    declarations = rule_resources.declared()
    print(rule_resources.table(peaks, declarations))
    assert set(peaks) == set(declarations) - NOT_IN_THE_CI_DAG, set(declarations) ^ set(peaks)
    # measured, not blank (a job of a fraction of a second ends before the first 0.5 s sample)
    assert all(peak["max_rss"] > 50 for peak in peaks.values() if peak["seconds"] > 2), peaks
    assert not rule_resources.over_declared(peaks, declarations)


def test_rule_resources_flags_a_rule_over_its_declaration(tmp_path):
    rules = tmp_path / "rules"
    rules.mkdir()
    (rules / "a.smk").write_text("rule fit:\n    threads: 1\n    resources:\n        mem_mb=1000,\n        runtime=2,\n\n"
                                 "rule draw:\n    resources:\n        mem_mb=500,\n        runtime=5,\n")
    declarations = rule_resources.declared(rules)
    assert declarations == {"fit": (1000.0, 2.0), "draw": (500.0, 5.0)}
    head = "s\th:m:s\tmax_rss\tmax_vms\n"
    for rule, rows in {"fit": ["30.0\t0:00:30\t900.5\t1200", "130.0\t0:02:10\t300\t400"], "draw": ["1.0\t0:00:01\t600\t700"]}.items():
        folder = tmp_path / "run" / "results" / "benchmarks" / rule
        folder.mkdir(parents=True)
        for i, row in enumerate(rows):
            (folder / f"{rule}_{i}.tsv").write_text(head + row + "\n")
    peaks = rule_resources.measured(tmp_path / "run")
    assert peaks == {"fit": {"max_rss": 900.5, "seconds": 130.0, "jobs": 2}, "draw": {"max_rss": 600.0, "seconds": 1.0, "jobs": 1}}
    over = rule_resources.over_declared(peaks, declarations)
    assert [line.split(":")[0] for line in over] == ["draw", "fit"]  # draw: memory; fit: 130 s > 2 min
    assert rule_resources.over_declared(peaks, {"fit": (1000.0, 3.0), "draw": (600.0, 5.0)}) == []
    assert rule_resources.suggest(peaks["fit"]) == (1500, 7)  # 900.5 x 1.5 -> 1500 MB; 130 s x 3 -> 7 min


@pytest.mark.xdist_group("dag")
def test_a_failing_rule_gives_its_slurm_log_and_error_and_a_rerun_submits_only_what_is_missing(on_slurm, failing_rule_run):
    """A tyre surface named with broken TeX makes exactly one rule fail (fig_tyre_curves: matplotlib
    cannot draw the legend); the KLE beside it succeeds. Fixed, the rerun submits only the figure.
    (The runs: tests/dag_runs.py ``failing_rule_runs``, started beside the first DAG run.)"""
    wd, future = failing_rule_run
    failed, made, logs, rerun = future.result()
    out = failed.stdout + failed.stderr
    assert failed.returncode != 0, out[-3000:]
    slurm_log = re.search(r"Error in group figures.*?\n\s*log: (\S+/(\d+)\.log)", out, re.DOTALL)
    assert slurm_log and (wd / slurm_log.group(1)).is_file(), out[-3000:]
    rule_log = re.search(r"Error in rule fig_tyre_curves:.*?\n\s*log: (\S+)", out, re.DOTALL)
    assert rule_log, out[-3000:]
    assert "Unknown symbol: \\undefinedmacro" in logs[rule_log.group(1)]
    assert made == ["results/data/kle.nc"]

    out = rerun.stdout + rerun.stderr
    assert rerun.returncode == 0, out[-3000:]
    assert sorted(set(re.findall(r"^\s*rule (\w+):$", out, re.MULTILINE))) == ["fig_tyre_curves"], out[-3000:]
    assert len(slurm_jobids(out)) == 1
    assert (wd / "results/figures/fig_2_3.png").is_file()


# --- the profile's sizing, with stand-ins for sinfo and scontrol (no cluster needed) ---

def _profile_with(tmp_path, sinfo, accounting="accounting_storage/slurmdbd", partition=None, min_job_age="300 sec"):
    """The slurm profile as Snakemake reads it (YTE), with sinfo printing ``sinfo`` lines."""
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir(exist_ok=True)
    (bin_dir / "sinfo").write_text(f"#!/bin/sh\ncat <<'EOF'\n{sinfo}\nEOF\n")
    (bin_dir / "scontrol").write_text(f"#!/bin/sh\necho 'AccountingStorageType   = {accounting}'\necho 'MinJobAge               = {min_job_age}'\n")
    for tool in ("sinfo", "scontrol"):
        (bin_dir / tool).chmod(0o755)
    text = (SLURM_PROFILE / "config.yaml").read_text()
    if partition:
        text = text.replace('PARTITION = ""', f'PARTITION = "{partition}"')
    (tmp_path / "config.yaml").write_text(text)
    code = textwrap.dedent("""
        import sys, yte
        from snakemake.profiles import ProfileConfigFileParser
        with open(sys.argv[1]) as fh:
            print(dict(ProfileConfigFileParser().parse(fh)))
    """)
    env = dict(os.environ, PATH=f"{bin_dir}:{os.environ['PATH']}")
    return subprocess.run([sys.executable, "-c", code, str(tmp_path / "config.yaml")], capture_output=True, text=True, env=env)


def test_the_profile_sizes_group_jobs_to_the_largest_node_of_the_partition(tmp_path):
    # %c %m %P per node: two small nodes and a big one in the default partition, a bigger one elsewhere
    done = _profile_with(tmp_path, "2 7800 batch*\n2 7800 batch*\n8 64000 batch*\n64 512000 bigmem")
    assert done.returncode == 0, done.stderr
    assert "'cores': '8'" in done.stdout and "'resources': ['mem_mb=64000']" in done.stdout, done.stdout
    assert "'slurm-status-command': 'squeue'" in done.stdout and "'slurm-init-seconds-before-status-checks': '5'" in done.stdout
    done = _profile_with(tmp_path, "2 7800 batch*\n64 512000 bigmem", partition="bigmem")
    assert "'cores': '64'" in done.stdout and "mem_mb=512000" in done.stdout and "slurm_partition='bigmem'" in done.stdout, done.stdout


def test_the_profile_asks_squeue_unless_squeue_forgets_ended_jobs_before_the_next_check(tmp_path):
    """Without accounting sacct fails on every query, and with sacct plugin 2.8.0 reads a job
    cancelled by hand ("CANCELLED by 0") as running: either way the run waits for ever. squeue keeps
    an ended job MinJobAge seconds; the plugin's checks come up to 180 s apart: sacct below 300 s."""
    done = _profile_with(tmp_path, "2 24000 debug*", accounting="accounting_storage/none", min_job_age="30 sec")
    assert "'slurm-status-command': 'squeue'" in done.stdout, done.stdout + done.stderr
    done = _profile_with(tmp_path, "2 24000 debug*", min_job_age="30 sec")
    assert "'slurm-status-command': 'sacct'" in done.stdout, done.stdout + done.stderr
    done = _profile_with(tmp_path, "2 24000 debug*", min_job_age="300 sec")
    assert "'slurm-status-command': 'squeue'" in done.stdout, done.stdout + done.stderr


def test_the_profile_stops_with_the_key_to_change_when_the_partition_has_no_node(tmp_path):
    done = _profile_with(tmp_path, "", partition="gpu")
    assert done.returncode != 0 and "set PARTITION at the top of workflow/profiles/slurm/config.yaml" in done.stderr, done.stderr

"""Shared fixtures: the repository's configs (validated) and small ensembles, one run of the DAG."""

import concurrent.futures
import copy
import os
import subprocess
import sys
from pathlib import Path

# Two xdist workers share two cores: BLAS threads on top of them only oversubscribe the cores, and
# OpenBLAS's idle threads spin (measured: the unit tests took 341 CPU-s with them, 272 without).
# Set before numpy loads; the CLI and Snakemake subprocesses inherit it (Snakemake sets each job's
# own count from its rule's `threads`). tests/test_threads.py raises the limit where it needs more.
for _variable in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import pytest  # noqa: E402
import yaml  # noqa: E402
from hypothesis import settings  # noqa: E402
from threadpoolctl import threadpool_limits  # noqa: E402

from uqdrive.config import load_config  # noqa: E402

# In case a plugin loaded numpy before this file: the same limit through threadpoolctl.
_ONE_BLAS_THREAD = threadpool_limits(limits=1, user_api="blas")

# Property tests draw the same examples on every run, so CI's verdict is a function of the code
# (a random draw once found a 1.1e-12 rounding case in CI's clean clone that no run before had
# met). `pytest --hypothesis-profile explore` draws new ones on every run, to hunt for such cases.
settings.register_profile("repeatable", derandomize=True, database=None)
settings.register_profile("explore", derandomize=False)
settings.load_profile("repeatable")

REPO = Path(__file__).resolve().parents[1]


def tiny_config(t_end: float = 0.8, samples: int = 12) -> dict:
    """The test config on a short grid (dt 0.02 s, t_end s), `samples` realisations and a cheap
    identification: a tiny ensemble for the CLI's edge tests, simulated in well under a second."""
    cfg = yaml.safe_load((REPO / "config" / "test.yaml").read_text())
    cfg["time"].update(t_end=t_end, dt=0.02, step=0.01)
    cfg["wind"]["kle_quadrature"] = 40
    cfg["montecarlo"]["samples"] = samples
    cfg["identification"].update(max_iter=15, order=1, quadrature_points=2)
    return cfg


def tiny_files(folder: Path) -> tuple[Path, Path]:
    """(config file, valid NLST ensemble file) of :func:`tiny_config` written into ``folder`` by
    the CLI itself (12 runs x 41 time points)."""
    from uqdrive.cli.main import main

    config = folder / "tiny.yaml"
    config.write_text(yaml.safe_dump(tiny_config()))
    data = folder / "tiny.nc"
    assert main(["simulate", "--model", "nlst", "--config", str(config), "--out", str(data)]) == 0
    return config, data


@pytest.fixture(scope="session")
def config():
    return load_config(REPO / "config" / "config.yaml")


@pytest.fixture
def cfg(config):
    """A mutable copy of the default config."""
    return copy.deepcopy(config)


@pytest.fixture(scope="session")
def _background():
    """One thread for the second DAG run (session end waits for it, should a test not have)."""
    with concurrent.futures.ThreadPoolExecutor(max_workers=1) as pool:
        yield pool


@pytest.fixture(scope="session")
def slurm():
    """None where Slurm takes jobs, else why not (tests/dag_runs.py slurm_unreachable)."""
    from dag_runs import slurm_unreachable

    return slurm_unreachable()


@pytest.fixture(scope="session")
def second_run(tmp_path_factory, _background, slurm):
    """The folder of the second DAG run (make reproduce, kill -9, then the Slurm run with Ctrl-C,
    scancel and resumption where Slurm answers, make reproduce elsewhere: tests/dag_runs.py), whether
    it ran on Slurm, and the future of what each step did; started, not awaited."""
    from dag_runs import interrupted_runs

    wd = tmp_path_factory.mktemp("interrupted")
    return wd, slurm is None, _background.submit(interrupted_runs, wd, slurm is None)


@pytest.fixture(scope="session")
def failing_rule_run(tmp_path_factory, slurm):
    """The folder of the failing-rule run on Slurm (tests/dag_runs.py ``failing_rule_runs``) and
    its future, in a thread of its own; None where Slurm takes no jobs. Started, not awaited."""
    from dag_runs import failing_rule_runs

    if slurm is not None:
        yield None
        return
    wd = tmp_path_factory.mktemp("failing_rule")
    with concurrent.futures.ThreadPoolExecutor(max_workers=1) as pool:
        yield wd, pool.submit(failing_rule_runs, wd)


@pytest.fixture(scope="session")
def workdir(request, tmp_path_factory):
    """A folder holding one uninterrupted run of the whole DAG on config/test.yaml (2 cores), shared
    by the tests of the "dag" xdist group, so the suite pays for it once. When the session holds
    tests of the second run or of the failing-rule run on Slurm, those start first and go on
    beside this one."""
    for background in ("second_run", "failing_rule_run"):
        if any(background in item.fixturenames for item in request.session.items):
            request.getfixturevalue(background)
    wd = tmp_path_factory.mktemp("dag")
    proc = subprocess.run([sys.executable, "-m", "snakemake", "-s", str(REPO / "Snakefile"), "--directory", str(wd),
                           "--configfile", str(REPO / "config" / "test.yaml"), "--cores", "2"], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return wd


def pytest_collection_modifyitems(config, items):
    """Longest first, so that the two xdist workers finish together: the DAG group (its runs take
    ~2-3 min; within it the tests of the first run, then that of the failing-rule run, then those
    that wait for the second run: each background run has had the first run's time to end), then
    the tests marked ``long(seconds)`` by decreasing time, then the rest in file order. (In file
    order the two-point sweep came last and one core idled for 22 s.)"""
    def rank(item):
        group = item.get_closest_marker("xdist_group")
        if group is not None and group.args and group.args[0] == "dag":
            return (0, 1.0 if "second_run" in item.fixturenames else 0.5 if "failing_rule_run" in item.fixturenames else 0.0)
        long = item.get_closest_marker("long")
        return (1, -float(long.args[0])) if long is not None else (2, 0.0)

    items.sort(key=rank)  # stable: equal ranks keep their file order



def pytest_terminal_summary(terminalreporter, config):
    """The Slurm run's wall time (tests/test_slurm.py writes it below the session's temporary
    folder, an xdist worker's included), in the summary whatever the capture settings."""
    factory = getattr(config, "_tmp_path_factory", None)
    if factory is None or factory._basetemp is None:  # no temporary folder was made
        return
    base = factory._basetemp
    for found in sorted(base.rglob("slurm_wall_time.txt")):
        terminalreporter.write_line(found.read_text().strip())

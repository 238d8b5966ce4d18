"""End-to-end: the whole Snakemake DAG on config/test.yaml, its report, lint and config errors."""

import csv
import subprocess
import sys

import pytest
import xarray as xr
import yaml

from conftest import REPO

# Every test of the DAG runs on one xdist worker, so the session-scoped `workdir` run happens once.
pytestmark = pytest.mark.xdist_group("dag")

SNAKEMAKE = [sys.executable, "-m", "snakemake"]


def _run(args, cwd):
    return subprocess.run(SNAKEMAKE + ["-s", str(REPO / "Snakefile"), "--directory", str(cwd)] + args, capture_output=True, text=True)


@pytest.mark.workflow
def test_dag_produces_every_figure_dataset_and_scorecard(workdir):
    results = workdir / "results"
    cfg = yaml.safe_load((REPO / "config" / "test.yaml").read_text())
    n_levels = len(cfg["noise"]["levels"])
    figures = {p.name for p in (results / "figures").iterdir()}
    expected = {"fig_2_3.png", "fig_5_2.png", "fig_7_1.png", "fig_5_3.png", "fig_5_4.png", "fig_pce_convergence.png"}
    expected |= {f"fig_6_{i}.png" for i in range(7, 19)} | {f"fig_B{i}.png" for i in range(1, 14)} | {"fig_gamma_sweep.png"}
    expected |= {f"fig_6_{i}.png" for i in range(1, 7)}
    expected |= {f"fig_A{n}.png" for n in range(1, 2 * n_levels + 1)}
    assert expected <= figures
    for model in ("lst", "nlst"):
        for steer in ("normal", "inverted"):
            ds = xr.open_dataset(results / "data" / f"ensemble_{model}_{steer}.nc")
            assert ds.sizes["sample"] == cfg["montecarlo"]["samples"]
            assert "config_hash" in ds.attrs
            ds.close()
    with open(results / "scorecard.csv") as fh:
        rows = list(csv.DictReader(fh))
    assert list(rows[0])[:8] == ["quantity", "source", "published", "reproduced", "tolerance", "status", "reason", "evidence"]
    # Published constants and formulas must pass; coverage and identification rows are statistics
    # of the tiny CI config (48 samples, few draws), so only their presence is checked here.
    statistical = ("coverage", "Table 6.", "(6.2)", "posterior", "shifts the other way", "Gamma", "discrepancy")
    assert rows and all(r["status"] == "pass" for r in rows if not any(k in r["quantity"] + r["source"] for k in statistical))
    assert any("coverage" in r["quantity"] for r in rows) and any("zeta" in r["quantity"] for r in rows)
    assert any("Table 6.2" in r["source"] for r in rows)
    assert any(r["quantity"].startswith("discrepancy:") for r in rows)


@pytest.mark.workflow
def test_report_and_up_to_date(workdir):
    proc = _run(["--configfile", str(REPO / "config" / "test.yaml"), "--cores", "1", "-n"], workdir)
    assert proc.returncode == 0 and "Nothing to be done" in proc.stdout + proc.stderr
    report = workdir / "report.html"
    proc = _run(["--configfile", str(REPO / "config" / "test.yaml"), "--report", str(report)], workdir)
    assert proc.returncode == 0, proc.stderr[-3000:]
    html = report.read_text()
    assert "Fig. 6.6" in html and "Fig. A.1" in html and "Scorecard" in html


@pytest.mark.workflow
def test_changing_a_config_value_reruns_its_dependants(workdir):
    proc = _run(["--configfile", str(REPO / "config" / "test.yaml"), "--config", "seed=5", "-n", "--cores", "1"], workdir)
    out = proc.stdout + proc.stderr
    assert proc.returncode == 0
    assert "ensemble" in out and "scorecard_foundation" not in out.split("Reasons")[0].split("Job stats")[-1]


def test_the_dag_group_keeps_one_worker(request):
    """pytest-xdist's loadgroup sends every test of the "dag" group to one worker by tagging its
    node id "@dag"; where that tag is lost (pytest 9.2 with xdist 3.8) the group's tests spread
    over the workers and each worker runs the session's DAG again (CI measured it: two DAG runs,
    4 minutes of the suite's 8)."""
    if not getattr(request.config.option, "loadgroup", False):  # set on xdist workers under --dist loadgroup
        pytest.skip("not on an xdist worker under --dist loadgroup")
    assert request.node.nodeid.endswith("@dag"), request.node.nodeid


def test_lint_is_clean():
    proc = subprocess.run(SNAKEMAKE + ["--lint"], capture_output=True, text=True, cwd=REPO)
    assert "Lints for" not in proc.stdout + proc.stderr


def test_invalid_config_stops_the_workflow_naming_the_key(tmp_path):
    cfg = yaml.safe_load((REPO / "config" / "test.yaml").read_text())
    cfg["wind"]["Tc"] = -2.0
    bad = tmp_path / "bad.yaml"
    bad.write_text(yaml.safe_dump(cfg))
    proc = _run(["--configfile", str(bad), "-n", "--cores", "1"], tmp_path)
    assert proc.returncode != 0
    assert "wind.Tc" in proc.stdout + proc.stderr
    assert not (tmp_path / "results").exists()

"""Parameter sweeps and the params they rest on: sweep files and their points (grid and zip), the
summary and its figure; rules that rerun exactly on the keys they read (a figure-only key
schedules no data job, the spin policy no ensemble); nested --config overrides typed and
validated like the file; one config hash for the CLI and the workflow; a two-point sweep."""

import csv
import importlib.util
import json
import re
import shlex
import subprocess
import sys
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pytest
import xarray as xr
import yaml

from conftest import REPO
from uqdrive.cli import main
from uqdrive.config import ConfigError, config_hash, load_config, parse_overrides, restrict_config
from uqdrive.plots.sweep import sweep_figure
from uqdrive.studies.sweep import COLLECTORS, SweepError, collect_targets, expand_points, load_sweep, parse_sweep
from uqdrive.studies.sweep.summary import numeric_axis, point_metrics, summary_dataset, summary_rows
from uqdrive.settings import ENSEMBLE_SETTINGS, ensemble_hash

SNAKEMAKE = [sys.executable, "-m", "snakemake", "-s", str(REPO / "Snakefile")]
TEST_CONFIG = str(REPO / "config" / "test.yaml")


def _snakemake(args, cwd):
    proc = subprocess.run(SNAKEMAKE + ["--configfile", TEST_CONFIG, "--directory", str(cwd)] + args, capture_output=True, text=True)
    return proc.returncode, proc.stdout + proc.stderr


def _scheduled(output):
    """Rule -> job count of a dry-run's "Job stats" table."""
    table = output.split("Job stats:")[-1].split("Reasons:")[0] if "Job stats:" in output else ""
    return {m[0]: int(m[1]) for m in re.findall(r"^(\w+)\s+(\d+)$", table, flags=re.M) if m[0] != "total"}


@pytest.fixture(scope="module")
def test_config():
    return load_config(TEST_CONFIG)


# --- sweep files and their points ---------------------------------------------------------------

def test_grid_is_every_combination_and_zip_takes_lists_together():
    grid = expand_points("grid", {"steering.delta_max_deg": [2.5, 5.0], "montecarlo.spin_policy": ["keep", "exclude", "keep"]})
    assert len(grid) == 6 and grid[0] == {"steering.delta_max_deg": 2.5, "montecarlo.spin_policy": "keep"}
    assert grid[3] == {"steering.delta_max_deg": 5.0, "montecarlo.spin_policy": "keep"}  # the last key varies fastest
    zipped = expand_points("zip", {"wind.sigma": [0.0, 200.0], "montecarlo.samples": [100, 400]})
    assert zipped == [{"wind.sigma": 0.0, "montecarlo.samples": 100}, {"wind.sigma": 200.0, "montecarlo.samples": 400}]
    with pytest.raises(SweepError, match="equal lengths"):
        expand_points("zip", {"wind.sigma": [0.0, 200.0], "montecarlo.samples": [100]})
    with pytest.raises(SweepError, match="non-empty list"):
        expand_points("grid", {"wind.sigma": []})
    with pytest.raises(SweepError, match="grid' or 'zip"):
        expand_points("product", {"wind.sigma": [1.0]})


def test_a_sweep_resolves_every_point_on_its_base(test_config):
    data = {"set": {"identification.runs": 3}, "zip": {"noise.levels": [[0.0, 0.2], [0.0, 0.5]], "wind.sigma": [50.0, 150.0]},
            "collect": ["identification.noise", "kl"], "description": "demo"}
    sweep = parse_sweep(data, "demo", test_config, "config/test.yaml")
    assert [p.name for p in sweep.points] == ["p00_levels=0,0.2_sigma=50", "p01_levels=0,0.5_sigma=150"]
    cfg = sweep.point_config("p01_levels=0,0.5_sigma=150", "results/sweeps/demo/p01")
    assert cfg["noise"]["levels"] == [0.0, 0.5] and cfg["wind"]["sigma"] == 150.0 and cfg["identification"]["runs"] == 3
    assert cfg["outdir"] == "results/sweeps/demo/p01" and cfg["seed"] == test_config["seed"]
    assert test_config["wind"]["sigma"] == 100.0  # the base is not changed
    assert collect_targets(sweep.collect, cfg) == ["data/identification_noise.nc", "data/kl_nlst_lst.nc"]
    with pytest.raises(SweepError, match="no point 'p09'"):
        sweep.point("p09")


@pytest.mark.parametrize("data, message", [
    ({"grid": {"steering.amplitude": [1.0]}, "collect": ["kl"]}, "steering.amplitude"),
    ({"grid": {"steering.delta_max_deg": [5.0, -1.0]}, "collect": ["kl"]}, r"p01_delta_max_deg=-1: config key 'steering.delta_max_deg'"),
    ({"grid": {"wind.sigma": [1.0]}, "collect": ["spins"]}, "unknown collector"),
    ({"grid": {"wind.sigma": [1.0]}, "zip": {"seed": [1]}, "collect": ["kl"]}, "exactly one of"),
    ({"grid": {"outdir": ["a"]}, "collect": ["kl"]}, "set per point"),
    ({"grid": {"wind.sigma": [1.0]}, "collect": ["kl"], "repeat": 2}, "unknown field"),
    ({"grid": {"wind.sigma": [1.0]}}, "'collect' must list"),
])
def test_a_bad_sweep_names_its_problem(test_config, data, message):
    with pytest.raises(SweepError, match=message):
        parse_sweep(data, "bad", test_config)


def test_shipped_sweeps_parse_and_stay_small():
    files = sorted((REPO / "config" / "sweeps").glob("*.yaml"))
    assert len(files) >= 4
    for path in files:
        sweep = load_sweep(path, search=[REPO])
        assert 2 <= len(sweep.points) <= 8 and sweep.description and sweep.base_path == "config/config.yaml", path.name
        cfg = sweep.point_config(sweep.points[0].name, "x")
        assert collect_targets(sweep.collect, cfg)
        assert not any(c == "scorecard" for c in sweep.collect), f"{path.name}: a scorecard needs the whole DAG per point"


def test_numeric_axis_of_scalars_lists_and_words():
    assert numeric_axis([2.5, 5, 10.0])[0].tolist() == [2.5, 5.0, 10.0]
    x, label = numeric_axis([[0.0, 0.15], [0.0, 0.3]])
    assert x.tolist() == [0.15, 0.3] and label == "[1]"
    assert numeric_axis(["keep", "exclude"]) == (None, "")
    assert numeric_axis([[1.0, 2.0], [3.0, 4.0]])[0] is None  # two positions vary: no single axis


def _identification_dataset(scale):
    estimates, params = ["LST-STD", "NLST-STD"], ["mu_mean", "mu_std", "l_f_mean", "l_f_std", "F_w_mean_low", "F_w_mean_high"]
    theta = np.broadcast_to(scale * np.array([1.0, 0.2, 1.55, 0.2, -400.0, 400.0]), (3, 2, 6)).copy()
    theta[0, 1] = np.nan  # a failed run is left out of the medians
    w2 = np.full((3, 2, 3), 0.1 * scale)
    w2[2] = 0.3 * scale
    return xr.Dataset({"theta": (("run", "estimate", "parameter"), theta), "w2": (("run", "estimate", "distribution"), w2),
                       "converged": (("run", "estimate"), np.array([[1, 0], [1, 1], [1, 1]], np.int8))},
                      coords={"run": [1, 2, 3], "estimate": estimates, "parameter": params, "distribution": ["mu", "l_f", "F_w_mean"]})


def test_point_metrics_summary_and_figure(test_config, tmp_path):
    sweep = parse_sweep({"grid": {"identification.fixed_deviation": [0.1, 0.3]}, "collect": ["identification.basic"]}, "demo", test_config)
    points = []
    for k, p in enumerate(sweep.points):
        folder = tmp_path / p.name
        (folder / "data").mkdir(parents=True)
        _identification_dataset(1.0 + k).to_netcdf(folder / "data" / "identification_basic.nc")
        cfg = sweep.point_config(p.name, str(folder))
        metrics = point_metrics(sweep.collect, folder, cfg)
        prov = {"config": f"{folder}/config.yaml", "config_hash": config_hash(cfg), "seed": cfg["seed"], "uqdrive_version": "x"}
        points.append({"name": p.name, "values": p.values, "metrics": metrics, "provenance": prov})
    first = points[0]["metrics"]
    assert first["identification.basic/w2_mu/LST-STD"] == pytest.approx(0.1)  # median of 0.1, 0.1, 0.3
    assert first["identification.basic/mu_mean/NLST-STD"] == pytest.approx(1.0)
    assert first["identification.basic/converged/NLST-STD"] == pytest.approx(2 / 3)
    assert len(first) == 2 * (3 + 6 + 1)
    ds = summary_dataset(sweep, json.loads(json.dumps(points)))
    assert ds.sizes == {"point": 2, "metric": 20, "key": 1}
    assert ds["swept_axis"].values[:, 0].tolist() == [0.1, 0.3]
    assert ds["value"].sel(metric="identification.basic/w2_mu/LST-STD").values.tolist() == pytest.approx([0.1, 0.2])
    ds.to_netcdf(tmp_path / "summary.nc")
    assert xr.open_dataset(tmp_path / "summary.nc")["config_hash"].values.tolist() == [p["provenance"]["config_hash"] for p in points]
    rows = summary_rows(ds)
    assert list(rows[0])[:2] == ["point", "identification.fixed_deviation"] and list(rows[0])[-4:] == ["config", "config_hash", "seed", "uqdrive_version"]
    assert rows[1]["identification.fixed_deviation"] == "0.3" and rows[1]["identification.basic/w2_mu/LST-STD"] == "0.2"
    fig = sweep_figure(ds)
    assert len(fig.axes) == 10  # a panel per quantity (3 W2, 6 parameters, converged), one swept key
    assert fig.axes[0].get_xlabel() == "" and fig.axes[-1].get_xlabel() == "identification.fixed_deviation"
    plt.close(fig)
    assert set(COLLECTORS) >= {"stability", "kl", "wheelslip", "identification.noise", "identification.initial_guess"}


# --- config: nested overrides, the restricted config of a rule, one hash ----------------------

def test_overrides_are_read_as_yaml_values():
    assert parse_overrides(['control={"R": 50}', "figures={band_sigmas: 2.0}", "seed=5", "control.gamma=0.1", "outdir=results/x"]) == {
        "control": {"R": 50, "gamma": 0.1}, "figures": {"band_sigmas": 2.0}, "seed": 5, "outdir": "results/x"}
    with pytest.raises(ConfigError, match="key=value"):
        parse_overrides(["seed"])


def test_a_rule_gets_exactly_its_keys_nested_as_in_the_file(test_config):
    part = restrict_config(test_config, ["seed", "montecarlo.samples", "wind"])
    assert part == {"seed": test_config["seed"], "montecarlo": {"samples": 48}, "wind": test_config["wind"]}
    with pytest.raises(KeyError, match="montecarlo.sample'"):
        restrict_config(test_config, ["montecarlo.sample"])


def test_one_hash_whatever_else_the_config_holds(test_config):
    """The CLI hands simulate_ensemble the whole config, the workflow only the keys the ensemble
    reads; both must write the same hash. Settings equal as numbers hash alike; outdir is no setting."""
    rule_part = restrict_config(test_config, ("seed",) + ENSEMBLE_SETTINGS + ("montecarlo.samples",))
    assert ensemble_hash(test_config, 48, 1) == ensemble_hash(rule_part, 48, 1) != ensemble_hash(test_config, 49, 1)
    assert ensemble_hash(test_config, 48, 1) != ensemble_hash(test_config, 48, 2)
    other = dict(test_config, outdir="elsewhere", figures=dict(test_config["figures"], band_sigmas=3))
    assert config_hash(other) == config_hash(test_config)


@pytest.mark.long(8)
def test_nested_config_overrides_are_typed_and_validated(tmp_path):
    rc, out = _snakemake(["-n", "--config", 'control={"R": 50}', "figures={band_sigmas: 2.0}"], tmp_path)
    assert rc == 0, out[-2000:]
    rc, out = _snakemake(["-n", "--config", 'control={"R": "fifty"}'], tmp_path)
    assert rc != 0 and "config key 'control.R'" in out and "number" in out
    assert not (tmp_path / "results").exists()


# --- a finished run (the suite's first DAG run, conftest's `workdir`): what a changed key reruns ---

#: The LST ensemble, its statistics and noise statistics, the KLE and their figures.
TARGETS = ["results/figures/fig_6_1.png", "results/figures/fig_5_2.png", "results/data/noise_stats_lst.nc"]


@pytest.mark.xdist_group("dag")  # on the worker that holds the DAG run
@pytest.mark.workflow
def test_a_figure_only_key_schedules_no_data_job(workdir):
    rc, out = _snakemake(TARGETS + ["-n", "--config", "figures={band_sigmas: 2.0}"], workdir)
    assert rc == 0, out[-2000:]
    assert _scheduled(out) == {"fig_data_band": 1}
    assert "before: {'figures.band_sigmas': 3.0} now: {'figures.band_sigmas': 2.0}" in out


@pytest.mark.xdist_group("dag")  # on the worker that holds the DAG run
@pytest.mark.workflow
def test_the_spin_policy_schedules_no_ensemble(workdir):
    rc, out = _snakemake(TARGETS + ["-n", "--config", "montecarlo={spin_policy: keep}"], workdir)
    assert rc == 0, out[-2000:]
    assert _scheduled(out) == {"statistics": 1, "noise_statistics": 1, "fig_data_band": 1}
    assert "now: {'montecarlo.spin_policy': 'keep'}" in out
    rc, out = _snakemake(["-n"] + TARGETS, workdir)
    assert rc == 0 and "Nothing to be done" in out


@pytest.mark.xdist_group("dag")  # on the worker that holds the DAG run
@pytest.mark.workflow
def test_cli_and_workflow_write_the_same_hash(workdir, tmp_path):
    out = tmp_path / "lst.nc"
    assert main(["simulate", "--model", "lst", "--config", TEST_CONFIG, "--out", str(out)]) == 0
    with xr.open_dataset(out) as cli, xr.open_dataset(workdir / "results" / "data" / "ensemble_lst_normal.nc") as wf:
        assert cli.attrs["config_hash"] == wf.attrs["config_hash"]
        np.testing.assert_allclose(cli["y"].values, wf["y"].values, rtol=1e-9, atol=1e-12)  # same draws (BLAS may round apart)


def test_every_rule_reads_only_its_keys():
    """Across the whole DAG (read from the rules' params): which rules a key reruns."""
    spec = importlib.util.spec_from_file_location("config_docs", REPO / "tools" / "config_docs.py")
    docs = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(docs)
    readers = docs.rule_readers()
    assert all(r.startswith("fig_") for r in docs.readers_of("figures.band_sigmas", readers))
    assert docs.readers_of("figures.kle_realisations", readers) == ["kle"]
    spin = docs.readers_of("montecarlo.spin_policy", readers)
    assert "statistics" in spin and not {"ensemble", "kle", "pce_moments", "mc_reference"} & set(spin)
    assert docs.readers_of("bayes.noise_level", readers) == ["posterior"]
    assert "scorecard_foundation" not in docs.readers_of("seed", readers)


# --- a two-point sweep on the CI config ---------------------------------------------------------

@pytest.mark.long(40)
@pytest.mark.workflow
def test_two_point_sweep(tmp_path):
    sweeps = tmp_path / "config" / "sweeps"
    sweeps.mkdir(parents=True)
    (sweeps / "two.yaml").write_text(yaml.safe_dump({
        "description": "spin policy on the CI config", "base": TEST_CONFIG,
        "grid": {"montecarlo.spin_policy": ["exclude", "keep"]}, "collect": ["stability", "kl"]}))
    rc, out = _snakemake(["--cores", "2", "results/sweeps/two/summary.csv"], tmp_path)
    assert rc == 0, out[-3000:]
    root = tmp_path / "results" / "sweeps" / "two"
    with open(root / "summary.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert [r["montecarlo.spin_policy"] for r in rows] == ["exclude", "keep"]
    assert {"point", "stability/n_spun/nlst normal", "kl/max/beta", "config", "config_hash", "seed", "uqdrive_version"} <= set(rows[0])
    assert rows[0]["config_hash"] != rows[1]["config_hash"] and rows[0]["config"].endswith("config.yaml")
    points = sorted(p.name for p in root.iterdir() if p.is_dir() and p.name.startswith("p"))
    configs = [yaml.safe_load((root / p / "config.yaml").read_text()) for p in points]
    assert [c["montecarlo"]["spin_policy"] for c in configs] == ["exclude", "keep"] and configs[1]["outdir"] == f"results/sweeps/two/{points[1]}"
    # the spin policy is not an ensemble's setting: the second point's ensembles are the first's (cache)
    ensembles = [(root / p / "data" / "ensemble_nlst_normal.nc").resolve() for p in points]
    assert ensembles[0] == ensembles[1] and ".cache" in str(ensembles[0])
    with xr.open_dataset(root / "summary.nc") as ds:
        assert ds.sizes["point"] == 2 and ds.attrs["sweep"] == "two"
    assert (root / "summary.png").stat().st_size > 0
    # everything is reused: a job is due only if a source of the repository was edited meanwhile
    rc, out = _snakemake(["-n", "results/sweeps/two/summary.csv"], tmp_path)
    reasons = re.findall(r"reason: (.*)", out)
    assert rc == 0 and ("Nothing to be done" in out or reasons), out[-2000:]
    assert all(r.startswith((f"Updated input files: {REPO}", "Input files updated by another job")) for r in reasons), reasons
    rc, out = _snakemake(["--report", str(tmp_path / "report.html"), "reported"], tmp_path)
    assert rc == 0, out[-3000:]
    assert "Sweep two" in (tmp_path / "report.html").read_text()


@pytest.mark.parametrize("goal, target", [("sweep", "results/sweeps/noise_levels/summary.csv"), ("reproduce", None)])
def test_make_hands_snakemake_its_config_and_target_apart(goal, target):
    """Every Snakemake call of `make sweep` and `make reproduce` (as `make -n` prints them), read
    by Snakemake's own argument parser: the config file is CONFIG alone and the sweep's summary a
    target. (--configfile takes every word after it: a target placed after it was read as a
    second config file and `make sweep` stopped with FileNotFoundError.)"""
    from snakemake.cli import get_argument_parser

    out = subprocess.run(["make", "-n", goal, "SWEEP=config/sweeps/noise_levels.yaml", "CONFIG=config/test.yaml", "CORES=2"],
                         cwd=REPO, capture_output=True, text=True, check=True).stdout
    calls = [shlex.split(line)[1:] for line in out.splitlines() if line.strip().split(" ")[0].endswith("bin/snakemake")]
    assert len(calls) == 2  # the run, then the report
    for argv in calls:
        args = get_argument_parser().parse_args(argv)
        assert [str(p) for p in args.configfile] == ["config/test.yaml"]
    run, report = (get_argument_parser().parse_args(a) for a in calls)
    assert list(run.targets) == ([target] if target else []) and run.report is None
    assert report.report and list(report.targets) == ["reported"]

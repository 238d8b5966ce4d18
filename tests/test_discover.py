"""`uqdrive discover` end to end on small hidden-effect ensembles made by other code
(uqdrive.studies.hidden_effects), and its refusals of bad input (exit 2, no verdict)."""

import copy
import json
import re

import numpy as np
import pytest
import yaml

from uqdrive.cli import main
from uqdrive.io import write_dataset
from uqdrive.studies.hidden_effects import HiddenEffectCase, generate

SAMPLES = 150


@pytest.fixture(scope="module")
def small(config):
    """A reduced but complete discovery: fewer model realisations, replicates and times."""
    c = copy.deepcopy(config)
    c["discrepancy"].update(model_samples=300, nonlinear_samples=100, bootstrap=40, max_times=60, top=2)
    return c


@pytest.fixture(scope="module")
def files(small, tmp_path_factory):
    root = tmp_path_factory.mktemp("discover")
    cfg_path = root / "config.yaml"
    cfg_path.write_text(yaml.safe_dump(small))
    cases = {
        "bank": HiddenEffectCase("bank", "road_bank", 3.0, "step", {"amplitude_deg": 2.0}, samples=SAMPLES, seed=11),
        "null": HiddenEffectCase("null", "none", 0.0, "chirp", {"amplitude_deg": 2.0}, samples=SAMPLES, seed=12),
    }
    paths = {}
    for name, case in cases.items():
        paths[name] = root / f"{name}.nc"
        write_dataset(generate(small, case), paths[name])
    return root, cfg_path, paths


def _run(args, capsys):
    code = main(args)
    return code, capsys.readouterr()


@pytest.mark.long(7)
def test_named_effect_repairs_the_model_and_the_model_file_is_used(files, capsys):
    """A 3 deg bank on a step steer (road_bank, phi = 3): named, its angle's 95 % interval holds
    3 deg, the gap at least halves, and model.yaml drives `simulate` and `identify`."""
    root, cfg, paths = files
    out = root / "bank_out"
    code, cap = _run(["discover", str(paths["bank"]), "--config", str(cfg), "--candidates", "road_bank,sensor_bias,wind_gust", "--out", str(out)], capsys)
    assert code == 0, cap.err
    v = json.loads((out / "verdict.json").read_text())
    assert v["effect"] == "road_bank"
    est, lo, hi = v["parameters"]["phi"]
    assert lo <= 3.0 <= hi and abs(est - 3.0) < 0.5
    assert v["gap_after"] <= 0.5 * v["gap_before"] and v["gap_before"] > 0
    assert v["localisation"] and {"signal", "statistic", "t_start", "t_end", "score"} <= set(v["localisation"][0])
    assert set(v["distributions"]) == {"before", "after"} and v["evidence"]["significant"]
    assert (out / "bands.png").stat().st_size > 0 and (out / "localisation.png").stat().st_size > 0
    model = yaml.safe_load((out / "model.yaml").read_text())
    assert model["effects"]["road_bank"]["phi"] == pytest.approx(est)
    sim = root / "sim.nc"
    assert main(["simulate", "--model", str(out / "model.yaml"), "--samples", "60", "--config", str(cfg), "--out", str(sim)]) == 0
    ident = root / "ident"
    assert main(["identify", str(paths["bank"]), "--model", str(out / "model.yaml"), "--config", str(cfg), "--out", str(ident)]) == 0
    e = json.loads((ident / "estimate.json").read_text())
    assert e["effects"] == {"road_bank": {"phi": pytest.approx(est)}} and abs(e["mu"][0] - 1.0) < 0.1
    # the fields and figure of plain identify; the baseline's warnings and the known quantities in the verdict
    assert {"warnings", "notes", "standard_errors", "intervals_95", "goodness_of_fit", "converged", "fixed"} <= set(e)
    assert (ident / "fit.png").stat().st_size > 0 and all(x is None or x > 0 for pair in e["standard_errors"].values() for x in pair)
    assert isinstance(v["warnings"], list) and v["fixed"] == {}


def test_null_case_says_none(files, capsys):
    """A case without a hidden effect is named none, with nothing to separate or sample; written
    without figures (--no-figures), the folder holds the verdict and the model alone."""
    root, cfg, paths = files
    out = root / "null_out"
    code, cap = _run(["discover", str(paths["null"]), "--config", str(cfg), "--out", str(out), "--no-figures"], capsys)
    assert code == 0, cap.err
    assert sorted(p.name for p in out.iterdir()) == ["model.yaml", "verdict.json"]  # --no-figures: no bands.png, localisation.png
    v = json.loads((out / "verdict.json").read_text())
    assert v["effect"] == "none" and v["ambiguous_with"] == [] and v["parameters"] == {} and v["separating_input"] == []
    assert "posterior" not in v  # sampled only for the config's effects (discrepancy.posterior.effects)
    assert not v["evidence"]["significant"] and v["effects"] == []


def _corrupt(ds, how):
    ds = ds.copy(deep=True)
    if how == "missing variable":  # any channel may be missing (issue 28), the steering may not
        return ds.drop_vars("delta")
    if how == "wrong dims":
        return ds.assign(psi=(("time", "sample"), ds["psi"].values.T, ds["psi"].attrs))
    if how == "NaN":
        ds["y"].values[3, 7] = np.nan
        return ds
    if how == "non-uniform time":
        t = ds["time"].values.copy()
        t[5:] += 0.003
        return ds.assign_coords(time=("time", t, ds["time"].attrs))
    if how == "too few samples":
        return ds.isel(sample=slice(0, 9))  # discover needs 10 (io.MIN_RUNS)
    return ds


@pytest.mark.parametrize("how", ["missing variable", "wrong dims", "NaN", "non-uniform time", "too few samples", "unknown candidate"])
def test_bad_input_is_refused_with_one_line_and_no_verdict(files, capsys, how):
    import xarray as xr

    root, cfg, paths = files
    bad = root / f"bad_{how.replace(' ', '_')}.nc"
    with xr.open_dataset(paths["null"]) as ds:
        _corrupt(ds.load(), how).to_netcdf(bad)
    out = root / f"out_{how.replace(' ', '_')}"
    extra = ["--candidates", "road_bank,tyre_wear"] if how == "unknown candidate" else []
    code, cap = _run(["discover", str(bad), "--config", str(cfg), "--out", str(out), *extra], capsys)
    assert code == 2
    assert len(cap.err.strip().splitlines()) == 1 and "Traceback" not in cap.err
    assert not out.exists() and not list(root.glob(f".{out.name}*"))


def _stub_discover(monkeypatch) -> dict:
    """Replace uqdrive.cli.api.discover by a stub whose verdict records what the command line
    hands on: ``posterior`` (at the call) and ``figures`` (at ``save``), into the dict returned."""
    from types import SimpleNamespace

    import uqdrive.cli.api as api

    seen = {}

    def fake(data, *, posterior=None, **_):
        seen["posterior"] = posterior
        return SimpleNamespace(save=lambda out, figures: seen.update(figures=figures), summary=lambda out=None: "", document={}, model_fits=True)

    monkeypatch.setattr(api, "discover", fake)
    return seen


@pytest.mark.parametrize("flag, expected", [([], None), (["--posterior"], True), (["--no-posterior"], False)])
def test_posterior_flag_reaches_the_finder(files, capsys, monkeypatch, flag, expected):
    """--posterior / --no-posterior override config discrepancy.posterior; without either the
    config decides (None). The finder's reading of True/False/None is tested in
    test_discrepancy_posterior; here the plumbing from the command line."""
    seen = _stub_discover(monkeypatch)
    root, cfg, paths = files
    code, cap = _run(["discover", str(paths["null"]), "--config", str(cfg), "--out", str(root / f"flag_{len(flag)}_{expected}"), *flag], capsys)
    assert code == 0, cap.err
    assert seen == {"posterior": expected, "figures": True}


def test_no_figures_reaches_the_writer(files, capsys, monkeypatch):
    """--no-figures: Verdict.save is asked for verdict.json and model.yaml alone (the writer's
    side: test_null_case_says_none)."""
    seen = _stub_discover(monkeypatch)
    root, cfg, paths = files
    code, cap = _run(["discover", str(paths["null"]), "--config", str(cfg), "--out", str(root / "no_figures"), "--no-figures"], capsys)
    assert code == 0, cap.err
    seen.pop("posterior")  # test_posterior_flag_reaches_the_finder's
    assert seen == {"figures": False}


def test_progress_lines_name_each_stage_and_the_verdict(files, small):
    """The workflow's log gets one line per finished stage with its seconds, then the verdict (a
    long rule reports progress): on the null case, the baseline, the null band and the verdict."""
    from uqdrive.cli.discover import discover_file

    root, _, paths = files
    lines = []
    v = discover_file(small, paths["null"], None, root / "progress_out", log=lines.append)
    assert [line.split(" done")[0] for line in lines[:2]] == ["discover: baseline", "discover: null_band"]
    assert all(re.search(r"done in \d+\.\d s", line) for line in lines[:2])
    assert lines[-1] == f"discover: verdict none, gap {v['gap_before']:.3g} -> {v['gap_after']:.3g}"

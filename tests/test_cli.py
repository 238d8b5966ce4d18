import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from uqdrive.cli.main import main
from uqdrive.io import read_ensemble

from conftest import REPO

CONFIG = str(REPO / "config" / "test.yaml")


def test_simulate_writes_a_valid_ensemble(tmp_path):
    out = tmp_path / "nlst.nc"
    rc = main(["simulate", "--model", "nlst", "--steer", "inverted", "--samples", "5", "--seed", "7", "--config", CONFIG, "--out", str(out)])
    assert rc == 0
    ds = read_ensemble(out)
    assert ds.sizes["sample"] == 5 and ds.attrs["seed"] == 7 and ds.attrs["steer"] == "inverted"


def test_simulate_with_noise_differs_from_clean(tmp_path):
    clean, noisy = tmp_path / "c.nc", tmp_path / "n.nc"
    assert main(["simulate", "--model", "lst", "--samples", "4", "--config", CONFIG, "--out", str(clean)]) == 0
    assert main(["simulate", "--model", "lst", "--samples", "4", "--noise", "0.05", "--config", CONFIG, "--out", str(noisy)]) == 0
    c, n = read_ensemble(clean), read_ensemble(noisy)
    assert n.attrs["noise_A"] == 0.05
    assert (c["mu"].values == n["mu"].values).all() and not (c["y"].values == n["y"].values).all()


def test_invalid_config_value_fails_cleanly(tmp_path, capsys):
    cfg = yaml.safe_load(Path(CONFIG).read_text())
    cfg["montecarlo"]["samples"] = "many"
    bad = tmp_path / "bad.yaml"
    bad.write_text(yaml.safe_dump(cfg))
    out = tmp_path / "x.nc"
    rc = main(["simulate", "--model", "lst", "--config", str(bad), "--out", str(out)])
    assert rc == 2
    err = capsys.readouterr().err
    assert "montecarlo.samples" in err and err.count("\n") == 1
    assert not out.exists() and list(tmp_path.iterdir()) == [bad]


def test_unwritable_output_fails_before_work(tmp_path, capsys):
    rc = main(["simulate", "--model", "lst", "--config", CONFIG, "--out", str(tmp_path / "no" / "x.nc")])
    assert rc == 2
    assert "does not exist" in capsys.readouterr().err


def test_unknown_model_exits_nonzero_via_console_script(tmp_path):
    exe = shutil.which("uqdrive", path=str(Path(sys.executable).parent))
    assert exe, "console script 'uqdrive' not installed next to the interpreter"
    out = tmp_path / "x.nc"
    proc = subprocess.run([exe, "simulate", "--model", "bicycle", "--config", CONFIG, "--out", str(out)], capture_output=True, text=True)
    assert proc.returncode == 2
    assert "invalid choice: 'bicycle'" in proc.stderr
    assert not out.exists()


@pytest.fixture(scope="module")
def measured(tmp_path_factory):
    path = tmp_path_factory.mktemp("m") / "lst.nc"
    assert main(["simulate", "--model", "lst", "--samples", "40", "--config", CONFIG, "--out", str(path)]) == 0
    return path


def test_identify_writes_estimate_json(measured, tmp_path):
    import json

    out = tmp_path / "est"
    assert main(["identify", str(measured), "--config", CONFIG, "--out", str(out), "--m-load", "105"]) == 0
    est = json.loads((out / "estimate.json").read_text())
    for key in ("mu", "l_f", "F_w_mean", "cost", "converged", "iterations"):
        assert key in est
    assert len(est["mu"]) == 2 and est["F_w_mean"][0] < est["F_w_mean"][1]
    assert (out / "fit.png").exists()
    assert est["state_scale"] == "none"  # the config's default: the thesis' SI residuals


def test_identify_state_scale_flag(measured, tmp_path):
    import json

    out = tmp_path / "est"
    assert main(["identify", str(measured), "--config", CONFIG, "--out", str(out), "--state-scale", "rms_mean"]) == 0
    est = json.loads((out / "estimate.json").read_text())
    assert est["state_scale"] == "rms_mean" and est["mu"][0] == pytest.approx(1.0, abs=0.2)


def _corrupt(src, dst, how):
    import xarray as xr

    ds = xr.load_dataset(src)
    if how == "missing":
        ds = ds.drop_vars("beta")
    elif how == "nan":
        ds["psi"][0, 5] = float("nan")
    elif how == "grid":
        ds = ds.assign_coords(time=ds["time"].values ** 1.1)
    elif how == "delta":
        ds = ds.drop_vars("delta").assign(delta=("t2", ds["delta"].values[:-3]))
    elif how == "one":
        ds = ds.isel(sample=[0])
    ds.to_netcdf(dst)


@pytest.mark.parametrize("how, message", [("missing", "missing variable 'beta'"), ("nan", "NaN"), ("grid", "uniform"),
                                          ("delta", "variable 'delta' has dims"), ("one", "at least 2")])
def test_identify_bad_input(measured, tmp_path, capsys, how, message):
    bad = tmp_path / "bad.nc"
    _corrupt(measured, bad, how)
    out = tmp_path / "out"
    assert main(["identify", str(bad), "--config", CONFIG, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1
    assert not (out / "estimate.json").exists()

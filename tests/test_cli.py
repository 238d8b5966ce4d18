import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from uqdrive.cli import main
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

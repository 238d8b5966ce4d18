"""The workflow reads its config as the command line does: YAML 1.2 numbers, a key given twice
refused, the files and --config overrides merged in Snakemake's order, without running the DAG."""

import subprocess
import sys

import pytest

from conftest import REPO
from uqdrive._errors import ConfigError
from uqdrive.workflow_config import workflow_config

TEST = REPO / "config" / "test.yaml"


def _variant(tmp_path, name, old, new):
    """config/test.yaml with the line holding ``old`` replaced by ``new``."""
    text = TEST.read_text()
    assert text.count(old) == 1
    path = tmp_path / name
    path.write_text(text.replace(old, new))
    return path


def test_a_number_in_exponent_form_is_a_number_and_sources_merge_in_snakemakes_order(tmp_path):
    """1.784e3 kg (YAML 1.1: the string '1.784e3', refused as not a number) is 1784.0; a
    --configfile overrides the workflow's file key by key, a --config entry overrides both."""
    sci = _variant(tmp_path, "sci.yaml", "m_base: 1784.0 ", "m_base: 1.784e3")
    part = tmp_path / "part.yaml"
    part.write_text("wind:\n  sigma: 250.0\n")
    config = workflow_config(REPO / "config" / "config.yaml", [sci, part], ["seed=7", 'control={"R": 50}'])
    assert config["vehicle"]["m_base"] == 1784.0 and isinstance(config["vehicle"]["m_base"], float)
    assert config["wind"]["sigma"] == 250.0 and config["wind"]["Tc"] == 2.0  # merged key by key
    assert config["montecarlo"]["samples"] == 48  # test.yaml's, over config.yaml's
    assert config["seed"] == 7 and config["control"]["R"] == 50
    assert workflow_config(None, [TEST])["montecarlo"]["samples"] == 48  # --replace-workflow-config: the given files alone


def test_a_key_given_twice_is_refused_naming_it_and_its_lines(tmp_path):
    twice = _variant(tmp_path, "twice.yaml", "  dt: 0.02 ", "  dt: 0.05\n  dt: 0.02 ")
    with pytest.raises(ConfigError, match=r"twice.yaml.*key 'dt' is given twice \(lines \d+ and \d+\)"):
        workflow_config(REPO / "config" / "config.yaml", [twice])


@pytest.mark.parametrize("edit, ok", [(("m_base: 1784.0 ", "m_base: 1.784e3"), True), (("  dt: 0.02 ", "  dt: 0.05\n  dt: 0.02 "), False)])
def test_the_workflow_reads_its_config_files_so(tmp_path, edit, ok):
    """Snakemake parses the workflow (listing its rules, no DAG): the exponent form runs, a key
    given twice stops it with one line naming the key."""
    path = _variant(tmp_path, "c.yaml", *edit)
    proc = subprocess.run([sys.executable, "-m", "snakemake", "-s", str(REPO / "Snakefile"), "--directory", str(tmp_path), "--configfile", str(path), "-l"],
                          capture_output=True, text=True)
    assert (proc.returncode == 0) == ok, proc.stderr[-2000:]
    if not ok:
        assert "invalid configuration: config file" in proc.stderr and "key 'dt' is given twice" in proc.stderr

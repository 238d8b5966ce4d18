"""The Python API (uqdrive.identify, discover, simulate) is what the command line runs: its results'
to_dict() are the files the CLI writes, summary() the line it prints; the status in two words,
--strict's exit status, the help's candidate list and the progress lines."""

import copy
import io
import json

import pytest
import yaml

import uqdrive
from uqdrive.cli.main import EXIT_MODEL_DOES_NOT_FIT, main
from uqdrive.config import load_config
from uqdrive.io import write_dataset

from conftest import REPO

CONFIG = str(REPO / "config" / "test.yaml")


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """40 runs of each single-track model on the test config's short grid."""
    root = tmp_path_factory.mktemp("api")
    paths = {}
    for model in ("lst", "nlst"):
        paths[model] = root / f"{model}.nc"
        write_dataset(uqdrive.simulate(model, config=CONFIG, samples=40), paths[model])
    return paths


def test_identify_result_equals_the_cli_files_and_line(runs, tmp_path, capsys):
    est = uqdrive.identify(runs["lst"], config=CONFIG, m_load=105.0)
    doc = est.to_dict()
    assert json.loads(json.dumps(doc)) == doc  # plain JSON, nothing numpy
    out = tmp_path / "cli"
    assert main(["identify", str(runs["lst"]), "--config", CONFIG, "--m-load", "105", "--out", str(out)]) == 0
    assert json.loads((out / "estimate.json").read_text()) == doc
    assert capsys.readouterr().out.splitlines()[0] == est.summary(out)
    # attributes: the distributions as tuples, the status words of a sound fit on its own model's data
    assert est.mu == tuple(doc["mu"]) and est.optimiser_converged and est.model_fits is True and est.converged
    assert "converged: optimiser converged, model fits" in est.summary()
    fig = est.plot()
    assert "model fits" in fig._suptitle.get_text()


def test_a_dataset_is_identified_as_its_file(runs):
    from uqdrive.io import read_ensemble

    a = uqdrive.identify(read_ensemble(runs["lst"]), config=load_config(CONFIG)).to_dict()
    b = uqdrive.identify(runs["lst"], config=CONFIG).to_dict()
    assert a.pop("measured") == "dataset" and b.pop("measured") == str(runs["lst"])
    assert a == b
    with pytest.raises(TypeError, match="unknown setting"):
        uqdrive.identify(runs["lst"], config=CONFIG, costs="std")


def test_a_misfit_on_a_good_optimum_is_told_apart_and_strict_exits_with_its_status(runs, tmp_path, capsys):
    """Non-linear data, linear model: the optimiser converges, the misfit test fails (the
    thesis' central finding); --strict turns that into the documented exit status."""
    est = uqdrive.identify(runs["nlst"], config=CONFIG)
    assert est.optimiser_converged and est.model_fits is False and not est.converged
    assert "NOT CONVERGED" in est.summary() and "optimiser converged, model does not fit" in est.summary()
    assert "model does not fit" in est.plot()._suptitle.get_text()
    assert main(["identify", str(runs["nlst"]), "--config", CONFIG, "--out", str(tmp_path / "a")]) == 0
    assert main(["identify", str(runs["nlst"]), "--config", CONFIG, "--strict", "--out", str(tmp_path / "b")]) == EXIT_MODEL_DOES_NOT_FIT
    assert (tmp_path / "b" / "estimate.json").exists()  # written all the same
    assert main(["identify", str(runs["lst"]), "--config", CONFIG, "--strict", "--out", str(tmp_path / "c")]) == 0
    capsys.readouterr()


@pytest.mark.long(16)
def test_discover_result_equals_the_cli_verdict(tmp_path, capsys):
    from uqdrive.studies.hidden_effects import HiddenEffectCase, generate

    cfg = copy.deepcopy(load_config(CONFIG))
    # a reduced but complete discovery (as tests/test_discover.py): few model runs and replicates
    cfg["discrepancy"].update(model_samples=300, nonlinear_samples=100, bootstrap=40, max_times=60, top=2)
    path, cfg_path = tmp_path / "bank.nc", tmp_path / "config.yaml"
    cfg_path.write_text(yaml.safe_dump(cfg))
    write_dataset(generate(cfg, HiddenEffectCase("bank", "road_bank", 3.0, "step", {"amplitude_deg": 2.0}, samples=150, seed=11)), path)
    lines = []
    v = uqdrive.discover(path, config=cfg, candidates=["road_bank", "wind_gust"], progress=lines.append, posterior=False)
    doc = v.to_dict()
    assert json.loads(json.dumps(doc)) == doc and v.effect == "road_bank" and v.model_fits
    assert lines[0] == "reading the ensemble" and len(lines) > 2
    out = tmp_path / "gap"
    assert main(["discover", str(path), "--config", str(cfg_path), "--candidates", "road_bank,wind_gust", "--no-posterior",
                 "--out", str(out)]) == 0
    written = json.loads((out / "verdict.json").read_text())
    # the run's own timings are the one field two identical runs do not share
    for d in (doc, written):
        d["evidence"].pop("seconds"), d["evidence"].pop("stage_seconds")
    assert written == doc
    assert capsys.readouterr().out.splitlines()[0] == v.summary(out)
    assert yaml.safe_load((out / "model.yaml").read_text()) == json.loads(json.dumps(v.model_document()))
    assert v.plot().axes and v.plot("localisation").axes


def test_discover_help_names_every_registered_effect():
    from uqdrive.cli.main import build_parser
    from uqdrive.vehicle.effects import EFFECTS

    parser = build_parser()
    text = parser._subparsers._group_actions[0].choices["discover"].format_help()
    missing = [name for name in EFFECTS if name not in text]
    assert not missing and "examples:" in text
    assert "(5." not in text and ">= 50" not in text


def test_every_help_has_an_example_and_no_equation_number():
    import re

    from uqdrive.cli.main import build_parser

    for name, command in build_parser()._subparsers._group_actions[0].choices.items():
        text = command.format_help()
        assert f"uqdrive {name}" in text.split("examples:")[-1], name
        assert not re.search(r"\(\d\.\d+\)|Table \d\.\d", text), name


def test_progress_lines_carry_the_elapsed_time_and_quiet_silences_them(runs, tmp_path, capsys, monkeypatch):
    from uqdrive.cli.progress import Progress

    stream = io.StringIO()
    Progress(stream=stream)("fitting")
    assert stream.getvalue().startswith("uqdrive: [") and " s] fitting" in stream.getvalue()
    quiet = io.StringIO()
    Progress(quiet=True, stream=quiet)("fitting")
    assert quiet.getvalue() == ""
    monkeypatch.setattr("uqdrive.cli.progress.is_terminal", lambda stream: True)
    assert main(["identify", str(runs["lst"]), "--config", CONFIG, "--out", str(tmp_path / "a")]) == 0
    err = capsys.readouterr().err
    assert "s] reading the ensemble" in err and "s] done" in err
    assert main(["identify", str(runs["lst"]), "--config", CONFIG, "--quiet", "--out", str(tmp_path / "b")]) == 0
    assert "s] " not in capsys.readouterr().err


def test_outputs_record_the_car_and_a_different_car_is_warned_of(runs):
    """simulate records the car in the file; identifying it with another car says so, naming the
    constants that differ in words and units; the same car gives no such warning (the control)."""
    made = json.loads(__import__("xarray").open_dataset(runs["lst"]).attrs["vehicle"])
    assert made["m_base"] == load_config(CONFIG)["vehicle"]["m_base"]
    same = uqdrive.identify(runs["lst"], config=CONFIG)
    assert same.vehicle == made and not any("record the car" in w for w in same.warnings)
    other = uqdrive.identify(runs["lst"], config=CONFIG, vehicle="bmw_320i")
    assert other.vehicle["name"] == "bmw_320i"
    warned = [w for w in other.warnings if "record the car" in w]
    assert len(warned) == 1 and "mass (kg) 1784 there, 1093.3 here" in warned[0] and "--vehicle" in warned[0]


def test_all_names_every_registered_candidate():
    from uqdrive.cli.api import candidate_names
    from uqdrive.vehicle.effects import EFFECTS, expand_names

    assert candidate_names(None) is None and candidate_names("road_bank") == ["road_bank"]
    every = candidate_names(["all"])
    assert every == list(EFFECTS) and expand_names(every) == list(EFFECTS)
    assert candidate_names(["sensor_bias", "all"])[0] == "sensor_bias" and set(candidate_names(["sensor_bias", "all"])) >= set(EFFECTS)


def test_the_packaged_car_is_named_when_nothing_names_a_car(tmp_path, capsys):
    """No --vehicle, no --config, no car in the file: a note says the packaged car was used; the
    same runs recording their car (the control) get none."""
    runs = uqdrive.simulate("lst", samples=10)
    bare, recorded = tmp_path / "bare.nc", tmp_path / "recorded.nc"
    write_dataset(runs, recorded)
    runs.attrs.pop("vehicle")
    write_dataset(runs, bare)
    assert main(["identify", str(bare), "--out", str(tmp_path / "a")]) == 0
    assert "note: no --vehicle given: fitted with the packaged config's car" in capsys.readouterr().err
    assert main(["identify", str(recorded), "--out", str(tmp_path / "b")]) == 0
    assert "no --vehicle given" not in capsys.readouterr().err

"""Bad input on the newer interfaces, as a user writes it: model.yaml files, output folders, a file
with two speeds, vehicle files in the wrong units and YAML 1.2 numbers. Each is refused with one
line naming the field and the fix, exit status 2 and nothing written, or read right."""

import copy
import os
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
import yaml

from uqdrive._yaml import DuplicateKeyError, load_yaml
from uqdrive.cli.main import _speed_notice, main
from uqdrive.config import ConfigError, load_config

from conftest import REPO
from test_edge_validation import files_under, refused, tiny  # noqa: F401 - the same fixture and checks
from test_vehicles import _car_file

VEHICLES = REPO / "config" / "vehicles"


# -- model.yaml ------------------------------------------------------------------------------------
MODEL = {"uqdrive_model": 1, "baseline": "lst", "effects": {"actuator_lag": {"T": 0.05}},
         "distributions": {"mu": {"mean": 1.0, "std": 0.1}, "l_f": {"mean": 1.55, "std": 0.1},
                           "F_w_mean": {"low": -400.0, "high": 400.0}, "m_load": {"mean": 80.0, "std": 10.0}}}


def _model(edit):
    def make():
        doc = copy.deepcopy(MODEL)
        edit(doc)
        return yaml.safe_dump(doc)
    return make


BAD_MODELS = {
    "effects_list": (_model(lambda d: d.update(effects=["actuator_lag"])), "'effects' is a list"),
    "scalar_effect": (_model(lambda d: d.update(effects={"actuator_lag": 0.05})), "actuator_lag: {T: <s>}"),
    "no_mu": (_model(lambda d: d["distributions"].pop("mu")), "distribution 'mu' is missing"),
    "distributions_list": (_model(lambda d: d.update(distributions=[{"mu": 1.0}])), "'distributions' is a list"),
    "mean_text": (_model(lambda d: d["distributions"]["mu"].update(mean="high")), "distributions.mu.mean = 'high' is not a number"),
    "nan_parameter": (_model(lambda d: d["effects"]["actuator_lag"].update(T=float("nan"))), "parameter T = nan s"),
    "negative_lag": (_model(lambda d: d["effects"]["actuator_lag"].update(T=-1.0)), "parameter T = -1 s is outside [0, 1] s"),
    "negative_mu_std": (_model(lambda d: d["distributions"]["mu"].update(std=-0.1)), "distributions.mu.std = -0.1"),
    "unknown_effect": (_model(lambda d: d.update(effects={"turbo": {"boost": 1.0}})), "effect 'turbo' is unknown"),
    "unknown_parameter": (_model(lambda d: d["effects"]["actuator_lag"].update(tau=0.1)), "has no parameter 'tau'"),
    "l_f_beyond_wheelbase": (_model(lambda d: d["distributions"]["l_f"].update(mean=3.5)), "beyond the wheelbase"),
    "low_above_high": (_model(lambda d: d["distributions"]["F_w_mean"].update(low=500.0)), "swap them"),
    "extra_field": (_model(lambda d: d["distributions"]["mu"].update(skew=1.0)), "write mu: {mean: <number>, std: <number>}"),
    "newer_version": (_model(lambda d: d.update(uqdrive_model=2)), "uqdrive_model = 2"),
    "duplicate_key": (lambda: yaml.safe_dump(MODEL).replace("baseline: lst\n", "baseline: lst\nbaseline: lst\n"),
                      "key 'baseline' is given twice"),
}


@pytest.mark.parametrize("command", ["simulate", "identify", "discover"])
@pytest.mark.parametrize("case", sorted(BAD_MODELS))
def test_bad_model_file_is_refused_by_every_command(tiny, tmp_path, capsys, case, command):
    make, needle = BAD_MODELS[case]
    model = tmp_path / "model.yaml"
    model.write_text(make())
    before = files_under(tmp_path)
    if command == "simulate":
        argv = ["simulate", "--model", str(model), "--samples", "4", "--out", str(tmp_path / "x.nc")]
    else:
        argv = [command, str(tiny[1]), "--model", str(model), "--out", str(tmp_path / "out")]
    refused(capsys, main(argv + ["--config", str(tiny[0])]), needle, "model file")
    assert files_under(tmp_path) == before


def test_a_good_model_file_is_read_with_its_values(tiny):
    from uqdrive.cli.model import load_model

    path = Path(tiny[0]).parent / "good_model.yaml"
    path.write_text(yaml.safe_dump(MODEL))
    structure, dist = load_model(path, load_config(tiny[0]))
    assert dict(structure.effects) == {"actuator_lag": (("T", 0.05),)} and structure.steering_lag == 0.05
    assert dist == MODEL["distributions"]


def test_a_model_files_load_reaches_the_simulator(tiny):
    """model.yaml's m_load N(80, 10) (the config's is N(100, 30)) is the load the augmented model
    simulates: a 300 kg load moves every state; without m_load the config's is kept."""
    from uqdrive.cli.model import model_settings, simulate_model
    from uqdrive.settings import Normal, Settings

    config = load_config(tiny[0])
    settings = Settings.from_config(config)
    assert model_settings(settings, MODEL["distributions"]).uncertainty.m_load == Normal(80.0, 10.0)
    assert model_settings(settings, {k: v for k, v in MODEL["distributions"].items() if k != "m_load"}) is settings
    folder = Path(tiny[0]).parent
    runs = {}
    for load in (80.0, 300.0):
        doc = copy.deepcopy(MODEL)
        doc["distributions"]["m_load"]["mean"] = load
        (folder / f"load_{load:g}.yaml").write_text(yaml.safe_dump(doc))
        runs[load] = simulate_model(config, folder / f"load_{load:g}.yaml", "normal", 4, 1)
    assert not np.allclose(runs[80.0]["psi_dot"].values, runs[300.0]["psi_dot"].values, rtol=1e-3)


# -- output folders -------------------------------------------------------------------------------
def test_discover_into_a_read_only_folder_is_refused_before_any_work(tiny, tmp_path, capsys, monkeypatch):
    """As root a chmod does not bind, so os.access reports the folder read-only instead."""
    folder = tmp_path / "ro"
    folder.mkdir()
    folder.chmod(0o555)
    real = os.access
    monkeypatch.setattr("os.access", lambda p, mode: False if Path(p) == folder and mode & os.W_OK else real(p, mode))
    monkeypatch.setattr("uqdrive.cli.discover.discover_file", lambda *a, **k: pytest.fail("the search ran"))
    try:
        refused(capsys, main(["discover", str(tiny[1]), "--config", str(tiny[0]), "--out", str(folder / "d")]), "not writable", "--out")
        assert list(folder.iterdir()) == []
    finally:
        folder.chmod(0o755)


@pytest.mark.parametrize("force", [False, True])
def test_discover_never_replaces_a_regular_file_with_a_folder(tiny, tmp_path, capsys, monkeypatch, force):
    target = tmp_path / "results"
    target.write_text("my notes")
    monkeypatch.setattr("uqdrive.cli.discover.discover_file", lambda *a, **k: pytest.fail("the search ran"))
    argv = ["discover", str(tiny[1]), "--config", str(tiny[0]), "--out", str(target)] + (["--force"] if force else [])
    refused(capsys, main(argv), "regular file", "choose another --out")
    assert target.read_text() == "my notes" and files_under(tmp_path) == {Path("results")}


# -- the car's speed ------------------------------------------------------------------------------
class _Stop(Exception):
    pass


def _two_speeds(tiny, tmp_path, v=19.0, v_c=25.0):
    ds = xr.load_dataset(tiny[1])
    ds["v"] = ("time", np.full(ds.sizes["time"], v), {"units": "m/s"})
    ds.attrs["v_c"] = v_c
    path = tmp_path / "two_speeds.nc"
    ds.to_netcdf(path)
    return path


def test_identify_discover_and_identify_model_use_the_same_speed(tiny, tmp_path, monkeypatch):
    """A file with v = 19 m/s and v_c = 25 m/s: every command runs its model at v."""
    data = _two_speeds(tiny, tmp_path)
    seen = {}

    def catch(name, speed):
        seen[name] = speed
        raise _Stop

    monkeypatch.setattr("uqdrive.cli.identify.LSTChaosModel", lambda settings, *a, **k: catch("identify", settings.vehicle.v_c))
    monkeypatch.setattr("uqdrive.cli.discover.DiscrepancyFinder", lambda settings, **k: catch("discover", settings.vehicle.v_c))
    monkeypatch.setattr("uqdrive.cli.model.AugmentedSimulator.drawn", lambda settings, t, d, v_c, *a, **k: catch("identify --model", v_c))
    model = tmp_path / "model.yaml"
    model.write_text(yaml.safe_dump(MODEL))
    for argv in (["identify"], ["discover"], ["identify", "--model", str(model)]):
        with pytest.raises(_Stop):
            main([argv[0], str(data), *argv[1:], "--config", str(tiny[0]), "--out", str(tmp_path / "o")])
    assert seen == pytest.approx({"identify": 19.0, "discover": 19.0, "identify --model": 19.0}, rel=1e-12)


def test_the_ignored_v_c_is_said_once(tiny, tmp_path, capsys):
    data = _two_speeds(tiny, tmp_path)
    _speed_notice(load_config(tiny[0]), data)
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "v = 19 m/s" in err and "v_c = 25 m/s is ignored" in err, err
    _speed_notice(load_config(tiny[0]), _two_speeds(tiny, tmp_path, v_c=19.0))  # agreeing: only the config's speed is replaced
    assert "ignored" not in capsys.readouterr().err


# -- vehicle files --------------------------------------------------------------------------------
def _car(tmp_path, text=None, **changes):
    path = Path(_car_file(tmp_path, **changes))
    if text is not None:
        path.write_text(text)
    return path


BAD_CARS = {
    "tonnes": (dict(mass=1.573, yaw_inertia=2.873), ["key 'mass' = 1.573 kg is not a car's (cars: 100 to 60000 kg)", "tonnes?", "1573 kg"]),
    "inertia_t_m2": (dict(yaw_inertia=2.873), ["key 'yaw_inertia' = 2.873 kg m^2", "t m^2?"]),
    "stiffness_kN": (dict(cornering_stiffness={"front": 160.0, "rear": 160.0}), ["cornering_stiffness.front' = 160 N/rad", "kN/rad?"]),
    "wheelbase_mm": (dict(wheelbase=2680.0), ["key 'wheelbase' = 2680 m", "mm?"]),
    "cg_height_mm": (dict(cg_height=550.0), ["key 'cg_height' = 550 m", "mm?"]),
    "track_width_tiny": (dict(track_width=0.01), ["key 'track_width' = 0.01 m is not a car's"]),
    "inertia_for_its_mass": (dict(mass=300.0, yaw_inertia=9e5), ["yaw_inertia / mass", "J0 = 3000 m^2", "their units"]),
    "mass_with_comma": (dict(mass="1,573"), ["key 'mass' (kg): '1,573'", "write a plain number"]),
    "no_source": (dict(source=None), ["key 'source' is missing", "where the numbers come from"]),
    "stiffness_scalar": (dict(cornering_stiffness=160000.0), ["key 'cornering_stiffness'", "write it as a mapping {front: ..., rear: ...}"]),
    "stiffness_no_rear": (dict(cornering_stiffness={"front": 160000.0}), ["key 'cornering_stiffness.rear' is missing; add rear (N/rad)"]),
}


@pytest.mark.parametrize("case", sorted(BAD_CARS))
def test_bad_vehicle_file_names_the_users_key(tiny, tmp_path, capsys, case):
    changes, needles = BAD_CARS[case]
    car = _car(tmp_path, **changes)
    before = files_under(tmp_path)
    err = refused(capsys, main(["identify", str(tiny[1]), "--vehicle", str(car), "--config", str(tiny[0]), "--out", str(tmp_path / "o")]),
                  *needles)
    assert "vehicle.J0" not in err and "vehicle.m_base" not in err and "config --dump" not in err
    assert files_under(tmp_path) == before


def test_a_duplicated_vehicle_key_is_refused_by_name(tmp_path):
    text = (VEHICLES / "rajamani_sedan.yaml").read_text().replace("mass: 1573.0", "mass: 1573.0\nmass: 1.573")
    with pytest.raises(ConfigError, match="key 'mass' is given twice"):
        load_config(None, vehicle=_car(tmp_path, text=text))


def test_yaml_1_2_numbers_are_numbers(tmp_path):
    """1.573e3 is a float in YAML 1.2 (PyYAML's 1.1 resolver reads it as text); 12 stays an int."""
    text = (VEHICLES / "rajamani_sedan.yaml").read_text().replace("mass: 1573.0", "mass: 1.573e3").replace("front: 160000.0", "front: 16e4")
    cfg = load_config(None, vehicle=_car(tmp_path, text=text))
    packaged = load_config(None, vehicle="rajamani_sedan")
    assert cfg["vehicle"] == {**packaged["vehicle"], "name": "car"} and cfg["tyre"] == packaged["tyre"]
    assert load_yaml("a: 1.573e3\nb: 1E-3\nc: 12\nd: 1e3x\ne: -.5e+2\n") == {"a": 1573.0, "b": 0.001, "c": 12, "d": "1e3x", "e": -50.0}
    with pytest.raises(DuplicateKeyError, match="lines 2 and 3"):
        load_yaml("a:\n  b: 1\n  b: 2\n")


def test_vehicle_file_of_a_config_is_found_beside_the_config(tmp_path, monkeypatch):
    folder = tmp_path / "project"
    folder.mkdir()
    _car(folder)
    (folder / "config.yaml").write_text((REPO / "config" / "config.yaml").read_text() + "\nvehicle_file: car.yaml\n")
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    cfg = load_config(folder / "config.yaml")
    assert cfg["vehicle"]["m_base"] == 1573.0 and cfg["vehicle"]["name"] == "car"

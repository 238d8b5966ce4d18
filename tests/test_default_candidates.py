"""discover searches every registered candidate by default; an effect that needs a constant the car
lacks is not searched but listed untestable with the reason, and discover still runs."""

import json

import pytest
import yaml

import uqdrive
from uqdrive.cli.discover import candidates_for_car
from uqdrive.cli.main import main
from uqdrive.config import load_config, load_schema
from uqdrive.io import write_dataset
from uqdrive.settings import Settings
from uqdrive.vehicle.effects import EFFECTS, FAMILIES, expand_names

import braking_runs as br

SENSORS = set(FAMILIES)


def test_the_packaged_default_searches_every_registered_candidate():
    """``candidates: all`` in the packaged config: the settings and the registry expand it to
    every registered effect, and the schema knows every registered name (a new effect added to
    the registry but not to the schema would be refused in a config)."""
    d = Settings.from_config(load_config(None)).discover
    assert d.candidates == ("all",) and expand_names(d.candidates) == list(EFFECTS)
    listed = load_schema()["properties"]["discrepancy"]["properties"]["candidates"]["oneOf"][1]["items"]["enum"]
    assert set(listed) == set(EFFECTS) | set(FAMILIES) | {"all"}


def test_every_required_constant_is_an_optional_quantity_of_the_car():
    """An effect's ``requires`` names constants the car's settings hold and the vehicle file
    documents (the untestable reason is worded from them); the two load transfers require some."""
    from uqdrive.settings import Vehicle
    from uqdrive.vehicle_spec import OPTIONAL_QUANTITIES

    required = {k for e in EFFECTS.values() for k in e.requires}
    assert required and required <= set(OPTIONAL_QUANTITIES) <= set(Vehicle.__dataclass_fields__)


def test_an_effect_is_untestable_exactly_when_the_car_lacks_what_it_requires(tmp_path):
    """The thesis car has no cg_height nor track_width: the two load transfers and the load-sensitive
    tyre are set aside with the constant each lacks; with cg_height the longitudinal transfer and
    the tyre are searched, the lateral transfer still needs the track width; every other
    registered effect needs nothing of the car."""
    bare = Settings.from_config(load_config(None, vehicle=br.vehicle_file(tmp_path, None))).vehicle
    high = Settings.from_config(load_config(None, vehicle=br.vehicle_file(tmp_path))).vehicle
    keep, untestable = candidates_for_car(list(EFFECTS), bare)
    assert [(u["registry_name"], u["needs"]) for u in untestable] == [("longitudinal_load_transfer", ["cg_height"]),
                                                                       ("lateral_load_transfer", ["cg_height", "track_width"]),
                                                                       ("load_sensitive_tyre", ["cg_height"])]
    assert "no cg_height (height of the centre of gravity above the ground, m); add it" in untestable[0]["reason"]
    assert keep == [n for n in EFFECTS if n not in ("longitudinal_load_transfer", "lateral_load_transfer", "load_sensitive_tyre")]
    keep, untestable = candidates_for_car(list(EFFECTS), high)
    assert [u["registry_name"] for u in untestable] == ["lateral_load_transfer"] and {"longitudinal_load_transfer", "load_sensitive_tyre"} <= set(keep)


@pytest.mark.long(30)
def test_braking_through_a_slalom_names_the_load_transfer_with_the_packaged_candidates(tmp_path):
    """The packaged config (its candidates untouched: all) and a vehicle file with cg_height on IMU
    runs of a car braking through a slalom, 40 runs, made by the hidden-effect reality with the
    centre of gravity 0.61 m above the ground: the longitudinal load transfer is named, no sensor
    effect, its height's 95 % interval holds 0.61 m and the gap closes; the lateral transfer, whose
    track width the file lacks, is listed untestable. Reduced settings (braking_runs.QUICK): the
    interval's half width there is ~0.08 m, so the estimate is asked within 0.1 m."""
    config = br.quick(load_config(None, vehicle=br.vehicle_file(tmp_path)))
    assert config["discrepancy"]["candidates"] == "all"
    v = uqdrive.discover(br.braking_runs(config), config=config)
    named = [e["effect"] for e in v.effects]
    assert named[0] == "longitudinal_load_transfer" and not SENSORS & set(named) and "unrecognised" not in named, named
    est, lo, hi = v.effects[0]["parameters"]["h"]
    assert lo <= br.HEIGHT <= hi and abs(est - br.HEIGHT) < 0.1
    assert v.gap_before > 0 and v.gap_after < 0.5 * v.gap_before
    assert [u["registry_name"] for u in v.untestable if u.get("needs")] == ["lateral_load_transfer"]
    assert "untestable: lateral_load_transfer (needs track_width)" in v.summary()


def test_without_cg_height_the_load_transfer_is_listed_untestable_and_discover_runs(tmp_path, capsys, monkeypatch):
    """The same runs and a vehicle file without cg_height, through the command line: exit 0, the
    longitudinal load transfer in verdict.json's untestable with the reason, in the printed line,
    and not searched (one cheap candidate besides it keeps the run short)."""
    import uqdrive.cli.discover as discover

    searched, real = [], discover.DiscrepancyFinder
    monkeypatch.setattr(discover, "DiscrepancyFinder", lambda settings, candidates, **k: searched.append(candidates) or real(settings, candidates, **k))
    car = br.vehicle_file(tmp_path, None)
    config = br.quick(load_config(None, vehicle=car))
    config["time"]["t_end"] = 3.0  # the braking's first second, and fewer model realisations, replicates and times: a cheap run
    config["discrepancy"].update(model_samples=60, bootstrap=30, max_times=20)
    runs = tmp_path / "runs.nc"
    write_dataset(br.braking_runs(config, samples=10), runs)
    cfg = tmp_path / "config.yaml"
    cfg.write_text(yaml.safe_dump({k: v for k, v in config.items() if k != "vehicle_file"}))
    code = main(["discover", str(runs), "--config", str(cfg), "--vehicle", str(car), "--candidates",
                 "road_bank,longitudinal_load_transfer", "--out", str(tmp_path / "out"), "--quiet"])
    out = capsys.readouterr().out
    assert code == 0
    v = json.loads((tmp_path / "out" / "verdict.json").read_text())
    assert [u["registry_name"] for u in v["untestable"]] == ["longitudinal_load_transfer"]
    assert v["untestable"][0]["reason"] == ("longitudinal_load_transfer: the car gives no cg_height (height of the centre of gravity "
                                            "above the ground, m); add it to the vehicle file (or the config's vehicle section) to test this effect")
    assert searched == [["road_bank"]]
    assert "untestable: longitudinal_load_transfer (needs cg_height)" in out


def test_a_candidate_set_the_car_cannot_test_at_all_is_refused(tmp_path, capsys):
    """Only effects the car lacks the constants for: nothing to search, one line naming what to
    add, exit 2, nothing written."""
    car = br.vehicle_file(tmp_path, None)
    runs = tmp_path / "runs.nc"
    write_dataset(br.braking_runs(br.quick(load_config(None, vehicle=car)), samples=10), runs)
    code = main(["discover", str(runs), "--vehicle", str(car), "--candidates", "longitudinal_load_transfer", "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert code == 2 and len(err.strip().splitlines()) == 1 and "add it to the vehicle file" in err
    assert not (tmp_path / "out").exists()


def test_discover_help_says_what_is_searched_by_default_and_what_each_effect_needs():
    from uqdrive.cli.main import build_parser

    text = " ".join(build_parser()._subparsers._group_actions[0].choices["discover"].format_help().split())
    assert "the packaged config searches every one of them (discrepancy.candidates: all)" in text
    assert "verdict.json's 'untestable' name it with the reason" in text
    for name, e in EFFECTS.items():
        if e.requires:
            assert f"{name} ({', '.join(f'{p} [{u}]' for p, u in zip(e.parameters, e.units))}); needs {', '.join(e.requires)}" in text

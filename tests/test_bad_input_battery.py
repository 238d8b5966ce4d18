"""A battery of the inputs a user tries on uqdrive's edges, as data: vehicle files, model.yaml,
channel subsets and units of measured files, a speed over time, output paths, YAML numbers and
duplicated keys, config overrides, ``uqdrive import`` and sweep files. Each case is refused
(exit status 2, one line on stderr naming the field and a fix, nothing written) or read right
(its parsed value asserted where the command hands it to its numerical core, which is stubbed
out: no case runs a fit). Every case runs in-process, so the whole battery costs seconds.
"""

from __future__ import annotations

import copy
import math
import os
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

import numpy as np
import pytest
import xarray as xr
import yaml

from uqdrive.cli.main import main
from uqdrive.config import ConfigError, load_config
from uqdrive.io import DataError
from uqdrive.studies.sweep import SweepError

from conftest import REPO, tiny_config, tiny_files

#: A refusal's line must say what to do: a verb of a fix, the rule it breaks or the names allowed.
FIX = re.compile(r"\b(give|write|add|choose|pass|remove|keep|convert|set|store|fix|record|swap|use|check|save|create|resample|"
                 r"interpolate|drop|subtract|map|declare|sort|repair|export|lower|raise|identify it|sweep only|must|needs|"
                 r"expected|allowed keys|known effects)\b", re.I)
VEHICLES = REPO / "src" / "uqdrive" / "vehicles"
SEDAN = yaml.safe_load((VEHICLES / "rajamani_sedan.yaml").read_text())
THESIS = yaml.safe_load((VEHICLES / "thesis.yaml").read_text())
MODEL = {"uqdrive_model": 1, "baseline": "lst", "effects": {"actuator_lag": {"T": 0.05}},
         "distributions": {"mu": {"mean": 1.0, "std": 0.1}, "l_f": {"mean": 1.55, "std": 0.1},
                           "F_w_mean": {"low": -400.0, "high": 400.0}}}
CHANNEL_MAP = {"psi_dot": {"channel": "YawRate", "units": "deg/s"}, "a_y": {"channel": "LatAcc", "units": "g"},
               "delta": {"channel": "Steer", "units": "deg", "steering_ratio": 15.0}, "v": {"channel": "Speed", "units": "km/h"},
               "time": {"channel": "t_ms", "units": "ms"}}


class Reached(Exception):
    """The command accepted its input and reached its numerical core (stubbed: nothing is fitted)."""

    def __init__(self, **seen):
        super().__init__("reached the numerical core")
        self.seen = seen


# -- the world every case builds on ----------------------------------------------------------------
@dataclass
class World:
    folder: Path
    config: Path
    data: Path
    ds: xr.Dataset
    base: dict

    def dataset(self) -> xr.Dataset:
        ds = self.ds.copy(deep=True)
        for name in ds.variables:
            ds[name].encoding = {}
        return ds


@pytest.fixture(scope="module")
def world(tmp_path_factory):
    """A tiny config and its valid NLST ensemble (12 runs x 41 points at 70 km/h), and ten short CSV recordings."""
    folder = tmp_path_factory.mktemp("battery")
    config, data = tiny_files(folder)
    t = np.arange(300) * 10.0  # ms
    for i in range(10):
        steer = 15.0 * np.sin(2 * np.pi * t / 1500.0) * (1 + 0.01 * i)
        rows = ["t_ms,YawRate,LatAcc,Steer,Speed"] + [f"{a:g},{0.3 * s:.6g},{0.01 * s:.6g},{s:.6g},{72.0 + 0.1 * i:g}"
                                                    for a, s in zip(t, steer)]
        (folder / f"run{i}.csv").write_text("\n".join(rows) + "\n")
    return World(folder, config, data, xr.load_dataset(data), load_config(config))


def files_under(folder: Path) -> set:
    return {p.relative_to(folder) for p in folder.rglob("*")}


# -- the numerical cores, stubbed: reaching one means the input was accepted -------------------------
@pytest.fixture
def stubs(monkeypatch):
    seen: dict = {}

    def statistics(ds, policy, channels=None):
        seen.update(ds=ds, channels=tuple(channels or ()))
        return real_statistics(ds, policy, channels)

    def chaos(settings, *a, **k):
        raise Reached(command="identify", settings=settings, **seen)

    class Finder:
        def __init__(self, settings, **kwargs):
            self.settings, self.kwargs = settings, kwargs

        def fit(self, ds):
            raise Reached(command="discover", settings=self.settings, ds=ds, **self.kwargs)

    def drawn(settings, t, delta, v_c, *a, **k):
        raise Reached(command="model", settings=settings, v_c=v_c, delta=delta, channels=k.get("channels"))

    def ensemble(settings, model, steer, **k):
        raise Reached(command="simulate", settings=settings, model=model, **k)

    def recordings(recordings, cmap, *a, **k):
        raise Reached(command="import", recordings=recordings, cmap=cmap)

    import uqdrive.cli.identify as identify

    real_statistics = identify.ensemble_statistics
    monkeypatch.setattr(identify, "ensemble_statistics", statistics)
    monkeypatch.setattr(identify, "LSTChaosModel", chaos)
    monkeypatch.setattr("uqdrive.cli.discover.DiscrepancyFinder", Finder)
    monkeypatch.setattr("uqdrive.cli.model.AugmentedSimulator.drawn", drawn)
    monkeypatch.setattr("uqdrive.vehicle.montecarlo.simulate_ensemble", ensemble)
    monkeypatch.setattr("uqdrive.recordings.importer.import_recordings", recordings)
    return seen


# -- cases -----------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Case:
    """``build(tmp, world)`` gives the argv of ``uqdrive`` (a list) or a call (no arguments) of an
    edge function; ``expect`` is "refused" (``pattern`` must match the one line) or "read" (``check``
    gets what the core was handed, or the call's value, and asserts the parsed values)."""

    name: str
    interface: str
    build: Callable[[Path, World], Any]
    expect: str
    pattern: str = ""
    check: Callable[..., Any] | None = None


CASES: list[Case] = []


def refuse(interface, name, build, pattern):
    CASES.append(Case(name, interface, build, "refused", pattern))


def read(interface, name, build, check):
    CASES.append(Case(name, interface, build, "read", check=check))


def write(path: Path, content) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    if isinstance(content, bytes):
        path.write_bytes(content)
    else:
        path.write_text(content if isinstance(content, str) else yaml.safe_dump(content, sort_keys=False))
    return path


def identify(tmp, w, data=None, *extra):
    return ["identify", str(data or w.data), "--config", str(w.config), "--out", str(tmp / "out"), *map(str, extra)]


def discover(tmp, w, data=None, *extra):
    return ["discover", str(data or w.data), "--config", str(w.config), "--out", str(tmp / "out"), *map(str, extra)]


def simulate(tmp, w, *extra, model="lst"):
    return ["simulate", "--model", str(model), "--samples", "4", "--config", str(w.config), "--out", str(tmp / "x.nc"), *map(str, extra)]


# -- vehicle files: --vehicle FILE and the config's vehicle_file ------------------------------------
def car(changes=None, base=SEDAN, text=None):
    """A vehicle file from ``base`` with ``changes`` (None drops a key); or the raw ``text``."""
    def make(tmp, w):
        if text is not None:
            return write(tmp / "car.yaml", text)
        spec = copy.deepcopy(base)
        for key, value in (changes or {}).items():
            if value is None:
                spec.pop(key, None)
            else:
                spec[key] = value
        return write(tmp / "car.yaml", spec)
    return make


def with_car(make, command=identify):
    return lambda tmp, w: command(tmp, w, None, "--vehicle", make(tmp, w)) if command is not simulate else \
        simulate(tmp, w, "--vehicle", make(tmp, w))


SEDAN_TEXT = (VEHICLES / "rajamani_sedan.yaml").read_text()
BAD_CARS = [
    ("mass_in_tonnes", {"mass": 1.573, "yaw_inertia": 2.873}, r"key 'mass' = 1\.573 kg is not a car's.*tonnes\? give it in kg \(1573 kg\)"),
    ("mass_zero", {"mass": 0.0}, r"key 'mass'.*(give a value > 0|physical range)"),
    ("mass_negative", {"mass": -1573.0}, r"key 'mass'.*> 0"),
    ("mass_nan", {"mass": math.nan}, r"key 'mass' is nan; give a finite number"),
    ("mass_inf", {"mass": math.inf}, r"key 'mass' is inf; give a finite number"),
    ("mass_with_unit", {"mass": "1573 kg"}, r"key 'mass' \(kg\): '1573 kg'.*write a plain number"),
    ("mass_a_list", {"mass": [1573.0]}, r"key 'mass' \(kg\).*number"),
    ("mass_of_a_ship", {"mass": 2e6}, r"key 'mass' = 2e\+06 kg is outside the physical range \(0, 100000\] kg; give"),
    ("mass_true", {"mass": True}, r"key 'mass' \(kg\).*number"),
    ("inertia_in_g_m2", {"yaw_inertia": 2.873e6}, r"key 'yaw_inertia' = 2\.873e\+06 kg m\^2.*g m\^2\?"),
    ("inertia_negative", {"yaw_inertia": -2873.0}, r"key 'yaw_inertia'.*> 0"),
    ("wheelbase_tiny", {"wheelbase": 0.5}, r"key 'wheelbase' = 0\.5 m is not a car's"),
    ("wheelbase_text", {"wheelbase": "2.68 m"}, r"key 'wheelbase' \(m\).*plain number"),
    ("cg_beyond_wheelbase", {"cg_to_front_axle": 3.0}, r"key 'cg_to_front_axle' = 3 m lies outside the wheelbase.*between 0 and"),
    ("cg_in_mm", {"cg_to_front_axle": 1100.0}, r"key 'cg_to_front_axle' = 1100 m.*\(0, 20\] m"),
    ("cg_negative", {"cg_to_front_axle": -1.1}, r"key 'cg_to_front_axle'.*> 0"),
    ("cg_twice", {"front_axle_load_share": 0.59}, r"keys 'cg_to_front_axle' and 'front_axle_load_share' both give.*keep one"),
    ("cg_missing", {"cg_to_front_axle": None}, r"key 'cg_to_front_axle' is missing; give the centre-of-gravity position"),
    ("share_percent", {"cg_to_front_axle": None, "front_axle_load_share": 59.0}, r"key 'front_axle_load_share'.*< 1"),
    ("share_one", {"cg_to_front_axle": None, "front_axle_load_share": 1.0}, r"key 'front_axle_load_share'.*< 1"),
    ("stiffness_negative", {"cornering_stiffness": {"front": -160000.0, "rear": 160000.0}}, r"cornering_stiffness\.front.*> 0"),
    ("stiffness_text", {"cornering_stiffness": {"front": "160 kN/rad", "rear": 160000.0}}, r"cornering_stiffness\.front.*number"),
    ("stiffness_list", {"cornering_stiffness": [160000.0, 160000.0]}, r"key 'cornering_stiffness'.*mapping \{front: \.\.\., rear: \.\.\.\}"),
    ("stiffness_extra_axle", {"cornering_stiffness": {"front": 1.6e5, "rear": 1.6e5, "middle": 1.6e5}},
     r"cornering_stiffness\.middle' is not known"),
    ("stiffness_and_magic_formula", {"magic_formula": THESIS["magic_formula"]}, r"keys 'cornering_stiffness' and 'magic_formula' both give.*keep one"),
    ("stiffness_missing", {"cornering_stiffness": None}, r"key 'cornering_stiffness' is missing; give the cornering stiffness"),
    ("no_description", {"description": None}, r"key 'description' is missing; add a line naming the car"),
    ("empty_description", {"description": ""}, r"key 'description'.*non-empty"),
    ("no_mass", {"mass": None}, r"key 'mass' is missing; add 'mass:' .* in kg"),
    ("no_wheelbase", {"wheelbase": None}, r"key 'wheelbase' is missing; add 'wheelbase:'"),
    ("misspelt_key", {"masse": 1573.0}, r"key 'masse' is not known; allowed keys"),
    ("internal_key", {"m_base": 1573.0}, r"key 'm_base' is not known; allowed keys"),
    ("speed_in_car", {"speed_kmh": 70.0}, r"key 'speed_kmh' is not known"),
    ("cg_height_mm", {"cg_height": 550.0}, r"key 'cg_height' = 550 m.*mm\?"),
    ("track_width_tiny", {"track_width": 0.01}, r"key 'track_width' = 0\.01 m is not a car's"),
    ("steering_ratio_negative", {"steering_ratio": -15.0}, r"key 'steering_ratio'.*> 0"),
    ("steering_ratio_text", {"steering_ratio": "15:1"}, r"key 'steering_ratio'.*number"),
]
for _name, _changes, _pattern in BAD_CARS:
    refuse("vehicle file", _name, with_car(car(_changes)), _pattern)

def _slips():
    """Every plausibility range of a car's number (vehicle_spec.PLAUSIBLE), missed by the unit slip it names."""
    from uqdrive.vehicle_spec import PLAUSIBLE

    for key, (lo, hi, unit, below, above) in PLAUSIBLE.items():
        value = {"mass": 1573.0, "yaw_inertia": 2873.0, "wheelbase": 2.68, "cg_to_front_axle": 1.1, "cg_height": 0.55, "track_width": 1.5,
                 "cornering_stiffness.front": 160000.0, "cornering_stiffness.rear": 160000.0}[key]
        for slip in filter(None, (below, above)):
            wrong = value / slip[1]
            head, _, axle = key.partition(".")
            changes = {head: {**SEDAN["cornering_stiffness"], axle: wrong}} if axle else {key: wrong}
            if key == "mass":
                changes["yaw_inertia"] = 2873.0 / slip[1]
            refuse("vehicle file", f"slip_{key}_in_{slip[0]}", with_car(car(changes)), rf"key '{re.escape(key)}' = {re.escape(format(wrong, 'g'))} .*({re.escape(slip[0])}\?|physical range .*give)")


_slips()
MF = lambda **front: {"front": {**THESIS["magic_formula"]["front"], **front}, "rear": dict(THESIS["magic_formula"]["rear"])}  # noqa: E731
for _name, _mf, _pattern in [
    ("mf_C_differs", MF(C=1.5), r"magic_formula\.front\.C' = 1\.5 differs from .*magic_formula\.rear\.C' = 1\.9.*give equal values"),
    ("mf_E_differs", MF(E=0.5), r"magic_formula\.front\.E' = 0\.5 differs.*give equal values"),
    ("mf_no_B", {"front": {"C": 1.9, "E": 0.97}, "rear": THESIS["magic_formula"]["rear"]}, r"magic_formula\.front\.B' is missing"),
    ("mf_B_negative", MF(B=-10.6), r"magic_formula\.front\.B.*> 0"),
    ("mf_C_huge", MF(C=19.0), r"magic_formula\.front\.C.*(10|range)"),
    ("mf_D_given", MF(D=1.0), r"magic_formula\.front\.D' is not known"),
]:
    refuse("vehicle file", _name, with_car(car({"magic_formula": _mf}, base=THESIS)), _pattern)

for _name, _text, _pattern in [
    ("duplicated_mass", SEDAN_TEXT.replace("mass: 1573.0", "mass: 1573.0\nmass: 1.573"), r"key 'mass' is given twice \(lines \d+ and \d+\); keep one"),
    ("a_list", "- mass: 1573\n", r"vehicle file '.*car\.yaml' must hold a mapping of keys"),
    ("empty", "", r"vehicle file '.*car\.yaml' must hold a mapping of keys"),
    ("not_yaml", "mass: [1573\n", r"vehicle file '.*car\.yaml' is not valid YAML"),
    ("tab_indented", "cornering_stiffness:\n\tfront: 1\n", r"vehicle file '.*car\.yaml' is not valid YAML"),
    ("latin1", SEDAN_TEXT.replace("textbook", "Lehrbuch für").encode("latin-1"), r"cannot read vehicle file '.*car\.yaml'.*UTF-8"),
]:
    refuse("vehicle file", _name, with_car(car(text=_text)), _pattern)

refuse("vehicle file", "yaw_moment_arm_too_long", with_car(car({"M_c": 120.0})), r"vehicle file '.*car\.yaml': M_c gives the model's M_c = 120 m, outside its range \[-100, 100\]")
refuse("vehicle file", "magic_formula_E_above_one", with_car(car({"magic_formula": {a: {"B": 10.6, "C": 1.9, "E": 1.5} for a in ("front", "rear")}},
                                                                  base=THESIS)), r"vehicle file '.*car\.yaml': key 'magic_formula\.(front|rear)\.E': 1\.5 is greater than the maximum of 1; give a value <= 1")
refuse("vehicle file", "stiffness_of_a_light_car", with_car(car({"mass": 100.0, "yaw_inertia": 100.0, "cornering_stiffness": {"front": 5e6, "rear": 5e6}})),
       r"vehicle file '.*car\.yaml': cornering_stiffness\.front .* gives the model's c_Sf = .* outside its range.*check those values")
refuse("vehicle file", "inertia_for_its_mass", with_car(car({"mass": 300.0, "yaw_inertia": 9e5})), r"yaw_inertia / mass.*J0 = 3000 m\^2.*check")
refuse("vehicle file", "missing_file", lambda tmp, w: identify(tmp, w, None, "--vehicle", tmp / "nosuch.yaml"),
       r"cannot read vehicle file '.*nosuch\.yaml': No such file.*give a packaged name")
refuse("vehicle file", "a_folder", lambda tmp, w: identify(tmp, w, None, "--vehicle", (tmp / "car.yaml").mkdir() or tmp / "car.yaml"),
       r"cannot read vehicle file '.*car\.yaml'.*give a packaged name")
refuse("vehicle file", "unknown_name", lambda tmp, w: identify(tmp, w, None, "--vehicle", "bmw"),
       r"unknown vehicle 'bmw'; choose one of .*bmw_320i")
refuse("vehicle file", "name_with_suffix_missing", lambda tmp, w: simulate(tmp, w, "--vehicle", "thesis.yml"),
       r"cannot read vehicle file 'thesis\.yml'")
refuse("vehicle file", "discover_tonnes", with_car(car({"mass": 1.573, "yaw_inertia": 2.873}), discover), r"key 'mass' = 1\.573 kg.*tonnes\?")
refuse("vehicle file", "simulate_tonnes", with_car(car({"mass": 1.573, "yaw_inertia": 2.873}), simulate), r"key 'mass' = 1\.573 kg.*tonnes\?")
refuse("vehicle file", "vehicles_command", lambda tmp, w: ["vehicles", str(car({"wheelbase": 2680.0})(tmp, w))], r"key 'wheelbase' = 2680 m.*mm\?")


def _vehicle(**expected):
    def check(seen):
        v = seen["settings"].vehicle
        for key, value in expected.items():
            assert getattr(v, key) == pytest.approx(value, rel=1e-12), (key, getattr(v, key))
    return check


read("vehicle file", "yaml_1_2_mass", with_car(car(text=SEDAN_TEXT.replace("mass: 1573.0", "mass: 1.573e3"))), _vehicle(m_base=1573.0))
read("vehicle file", "integer_mass", with_car(car({"mass": 1573})), _vehicle(m_base=1573.0, J0=2873.0 / 1573.0))
read("vehicle file", "stiffness_exponent", with_car(car(text=SEDAN_TEXT.replace("front: 160000.0", "front: 16e4"))),
     _vehicle(c_Sf=160000.0 / (1573.0 * 9.81 * 1.58 / 2.68 * 1.9)))
read("vehicle file", "front_axle_share", with_car(car({"cg_to_front_axle": None, "front_axle_load_share": 0.59})),
     lambda seen: seen["settings"].uncertainty.l_f.mean == pytest.approx(2.68 * 0.41, rel=1e-12))
read("vehicle file", "byte_order_mark", with_car(car(text=b"\xef\xbb\xbf" + SEDAN_TEXT.encode())), _vehicle(m_base=1573.0))
read("vehicle file", "magic_formula_gives_the_tyre", with_car(car(base=THESIS), discover), _vehicle(C=1.9, E=0.97, c_Sf=10.6, c_Sr=30.4))
read("vehicle file", "packaged_name", lambda tmp, w: simulate(tmp, w, "--vehicle", "bmw_320i"), _vehicle(m_base=1093.3, wheelbase=2.5789))
read("vehicle file", "optional_quantities", with_car(car({"cg_height": 0.55, "track_width": 1.5, "steering_ratio": 15.3})),
     _vehicle(cg_height=0.55, track_width=1.5, steering_ratio=15.3))


def config_file(edit=None, text=None, name="config.yaml"):
    """A config file (the tiny one) edited by ``edit(cfg)``, or the raw ``text``."""
    def make(tmp, w):
        if text is not None:
            return write(tmp / name, text(w) if callable(text) else text)
        cfg = tiny_config()
        if edit:
            edit(cfg)
        return write(tmp / name, cfg)
    return make


def with_config(make, command=identify):
    def build(tmp, w):
        path = make(tmp, w)
        argv = command(tmp, w)
        argv[argv.index("--config") + 1] = str(path)
        return argv
    return build


def _vehicle_file(ref):
    return lambda c: c.update(vehicle_file=ref)


def _beside(tmp, w):
    (tmp / "cars").mkdir()
    write(tmp / "cars" / "mine.yaml", SEDAN)
    cfg = tiny_config()
    cfg["vehicle_file"] = "mine.yaml"
    path = write(tmp / "cars" / "config.yaml", cfg)
    argv = identify(tmp, w)
    argv[argv.index("--config") + 1] = str(path)
    return argv


read("vehicle file", "config_vehicle_file_beside_the_config", _beside, _vehicle(m_base=1573.0))
refuse("vehicle file", "config_vehicle_file_missing", with_config(config_file(_vehicle_file("nosuch.yaml"))),
       r"cannot read vehicle file '.*nosuch\.yaml'")
refuse("vehicle file", "config_vehicle_file_number", with_config(config_file(_vehicle_file(12))), r"config key 'vehicle_file'.*string")
refuse("vehicle file", "config_vehicle_file_unknown_name", with_config(config_file(_vehicle_file("golf"))), r"unknown vehicle 'golf'")
read("vehicle file", "flag_replaces_config_vehicle_file",
     lambda tmp, w: with_config(config_file(_vehicle_file("thesis")))(tmp, w) + ["--vehicle", "rajamani_sedan"], _vehicle(m_base=1573.0))
refuse("vehicle file", "config_section_in_tonnes", with_config(config_file(lambda c: (c["vehicle"].pop("m_base"), c["vehicle"].update(mass=1.784)))),
       r"config key 'vehicle\.mass' = 1\.784 kg is not a car's.*tonnes\?")
refuse("vehicle file", "config_section_mass_twice", with_config(config_file(lambda c: c["vehicle"].update(mass=1784.0))),
       r"config keys 'vehicle\.mass' and 'vehicle\.m_base' both give the mass.*keep one")
refuse("vehicle file", "config_m_base_in_tonnes", with_config(config_file(lambda c: c["vehicle"].update(m_base=1.784))),
       r"config key 'vehicle\.m_base' = 1\.784 kg is not a car's.*tonnes\?")
refuse("vehicle file", "config_cg_height_in_mm", with_config(config_file(lambda c: c["vehicle"].update(cg_height=550.0))),
       r"config key 'vehicle\.cg_height' = 550 m is not a car's.*mm\? give it in m \(0\.55 m\)")
refuse("vehicle file", "config_track_width_tiny", with_config(config_file(lambda c: c["vehicle"].update(track_width=0.01))),
       r"config key 'vehicle\.track_width' = 0\.01 m is not a car's")
refuse("vehicle file", "config_J0_as_inertia", with_config(config_file(lambda c: c["vehicle"].update(J0=1498.56))),
       r"config key 'vehicle\.J0' = 1498\.56 is outside the physical range.*m\^2")


# -- model.yaml: identify/discover/simulate --model --------------------------------------------------
def model_file(edit=None, text=None):
    def make(tmp, w):
        if text is not None:
            return write(tmp / "model.yaml", text)
        doc = copy.deepcopy(MODEL)
        if edit:
            edit(doc)
        return write(tmp / "model.yaml", doc)
    return make


COMMANDS = {"identify": lambda tmp, w, m: identify(tmp, w, None, "--model", m),
            "discover": lambda tmp, w, m: discover(tmp, w, None, "--model", m),
            "simulate": lambda tmp, w, m: simulate(tmp, w, model=m)}


def with_model(make, command):
    return lambda tmp, w: COMMANDS[command](tmp, w, make(tmp, w))


def _eff(**effects):
    return lambda d: d.update(effects=effects)


def _dist(name, **fields):
    return lambda d: d["distributions"].__setitem__(name, fields) if fields else d["distributions"].pop(name)


def _field(name, **fields):
    return lambda d: d["distributions"][name].update(fields)


BAD_MODELS = [
    ("effect_params_list", _eff(actuator_lag=[0.05]), r"effect 'actuator_lag' is \[0\.05\], not its parameters; write actuator_lag: \{T: <s>\}"),
    ("effect_param_text", _eff(actuator_lag={"T": "50 ms"}), r"parameter T = '50 ms' is not a number; give a finite number in \[0, 1\] s"),
    ("effect_param_bool", _eff(actuator_lag={"T": True}), r"parameter T = True is not a number"),
    ("effect_param_null", _eff(actuator_lag={"T": None}), r"parameter T = None is not a number"),
    ("effect_param_inf", _eff(actuator_lag={"T": math.inf}), r"parameter T = inf s is outside \[0, 1\] s"),
    ("lag_in_ms", _eff(actuator_lag={"T": 50.0}), r"parameter T = 50 s is outside \[0, 1\] s"),
    ("effect_missing_param", _eff(actuator_lag={}), r"effect 'actuator_lag' lacks parameter 'T'"),
    ("effect_two_params_one_missing", _eff(roll_steer={"K": 0.5, "f": 1.5}), r"effect 'roll_steer' lacks parameter 'zeta'.*zeta: <number>"),
    ("bank_in_radians_too_far", _eff(road_bank={"phi": 45.0}), r"effect 'road_bank' parameter phi = 45 deg is outside \[-10, 10\] deg"),
    ("sensor_bias_wrong_channel", _eff(sensor_bias_psi_dot={"offset_psi": 0.01}), r"effect 'sensor_bias_psi_dot' has no parameter 'offset_psi'"),
    ("family_name", _eff(sensor_bias={"offset": 0.01}), r"effect 'sensor_bias' is unknown; known effects"),
    ("effect_number_name", lambda d: d.update(effects={1: {"T": 0.1}}), r"effect '1' is unknown"),
    ("effects_text", lambda d: d.update(effects="actuator_lag"), r"'effects' is a str; map each effect to its parameters"),
    ("missing_l_f", _dist("l_f"), r"distribution 'l_f' is missing; give all of mu, l_f and F_w_mean"),
    ("missing_wind", _dist("F_w_mean"), r"distribution 'F_w_mean' is missing"),
    ("mu_scalar", lambda d: d["distributions"].update(mu=1.0), r"distribution 'mu' is 1\.0; write mu: \{mean: <number>, std: <number>\}"),
    ("mu_without_std", _dist("mu", mean=1.0), r"distribution 'mu' is \{'mean': 1\.0\}; write mu: \{mean"),
    ("mu_std_nan", _field("mu", std=math.nan), r"distributions\.mu\.std = nan is outside \[0, 10\]; give a finite number.*\(0: known\)"),
    ("mu_mean_zero", _field("mu", mean=0.0), r"distributions\.mu\.mean = 0 is outside \(0, 10\]"),
    ("mu_mean_negative", _field("mu", mean=-1.0), r"distributions\.mu\.mean = -1 is outside"),
    ("l_f_mean_negative", _field("l_f", mean=-1.55), r"distributions\.l_f\.mean = -1\.55 m is outside \(0, 20\) m"),
    ("l_f_std_text", _field("l_f", std="0.1 m"), r"distributions\.l_f\.std = '0\.1 m' is not a number"),
    ("wind_as_mean_std", _dist("F_w_mean", mean=0.0, std=100.0), r"distribution 'F_w_mean' is .*; write F_w_mean: \{low: <N>, high: <N>\}"),
    ("wind_in_kN_text", _field("F_w_mean", low="-0.4 kN"), r"distributions\.F_w_mean\.low = '-0\.4 kN' is not a number"),
    ("m_load_negative", _dist("m_load", mean=-80.0, std=10.0), r"distributions\.m_load\.mean = -80 kg is outside \[0, 100000\] kg"),
    ("m_load_std_negative", _dist("m_load", mean=80.0, std=-10.0), r"distributions\.m_load\.std = -10 kg is outside"),
    ("m_load_in_tonnes_text", _dist("m_load", mean="0.08 t", std=10.0), r"distributions\.m_load\.mean = '0\.08 t' is not a number"),
    ("unknown_distribution", _dist("g", mean=9.81, std=0.0), r"distribution 'g' is unknown; give mu, l_f, F_w_mean, m_load"),
    ("distributions_null", lambda d: d.update(distributions=None), r"'distributions' is a NoneType; write them as a mapping"),
    ("distributions_text", lambda d: d.update(distributions="prior"), r"'distributions' is a str; write them as a mapping"),
    ("baseline_nlst", lambda d: d.update(baseline="nlst"), r"is not a uqdrive model file \(needs baseline: lst.*write one with `uqdrive discover`"),
    ("no_baseline", lambda d: d.pop("baseline"), r"is not a uqdrive model file"),
    ("no_distributions", lambda d: d.pop("distributions"), r"is not a uqdrive model file"),
    ("version_text", lambda d: d.update(uqdrive_model="1"), r"uqdrive_model = '1'; this uqdrive reads version 1"),
]
_commands = ("identify", "discover", "simulate")
for _i, (_name, _edit, _pattern) in enumerate(BAD_MODELS):
    refuse("model.yaml", f"{_name}[{_commands[_i % 3]}]", with_model(model_file(_edit), _commands[_i % 3]), _pattern)

for _i, (_name, _text, _pattern) in enumerate([
    ("a_list", "- baseline: lst\n", r"is not a uqdrive model file"),
    ("empty", "", r"is not a uqdrive model file"),
    ("not_yaml", "baseline: [lst\n", r"cannot read model file '.*model\.yaml'.*give the model\.yaml that uqdrive discover wrote"),
    ("binary", b"\x89PNG\r\n\x1a\n\x00\x00", r"cannot read model file '.*model\.yaml'"),
    ("duplicated_effect", yaml.safe_dump(MODEL).replace("  actuator_lag:\n", "  actuator_lag:\n    T: 0.1\n  actuator_lag:\n"),
     r"key 'actuator_lag' is given twice"),
    ("duplicated_mean", yaml.safe_dump(MODEL).replace("    mean: 1.0\n", "    mean: 1.0\n    mean: 2.0\n", 1), r"key 'mean' is given twice"),
]):
    refuse("model.yaml", f"{_name}[{_commands[_i % 3]}]", with_model(model_file(text=_text), _commands[_i % 3]), _pattern)

refuse("model.yaml", "missing_file[identify]", lambda tmp, w: COMMANDS["identify"](tmp, w, tmp / "nosuch.yaml"),
       r"cannot read model file '.*nosuch\.yaml': No such file")
refuse("model.yaml", "a_folder[discover]", lambda tmp, w: COMMANDS["discover"](tmp, w, (tmp / "m.yaml").mkdir() or tmp / "m.yaml"),
       r"cannot read model file '.*m\.yaml'")
refuse("model.yaml", "not_yaml_suffix[simulate]", lambda tmp, w: simulate(tmp, w, model=write(tmp / "model.txt", MODEL)),
       r"--model '.*model\.txt' is neither lst, nlst nor a model file; give lst, nlst or the model\.yaml")
refuse("model.yaml", "l_f_beyond_the_vehicle_files_wheelbase[identify]",
       lambda tmp, w: COMMANDS["identify"](tmp, w, model_file(_field("l_f", mean=2.6))(tmp, w)) + ["--vehicle", "bmw_320i"],
       r"distributions\.l_f\.mean = 2\.6 m lies beyond the wheelbase 2\.5789 m")


LLT = _eff(lateral_load_transfer={"chi_f": 0.5, "p_Dz": -0.2})
refuse("model.yaml", "effect_the_car_cannot_carry[simulate]", with_model(model_file(LLT), "simulate"),
       r"effect 'lateral_load_transfer' needs the car's cg_height .* add it to the vehicle file")
refuse("model.yaml", "effect_the_car_cannot_carry[identify]", with_model(model_file(LLT), "identify"), r"needs the car's cg_height")
read("model.yaml", "effect_the_vehicle_file_carries[simulate]", lambda tmp, w: with_model(model_file(LLT), "simulate")(tmp, w) + ["--vehicle", "bmw_320i"],
     lambda seen: seen["settings"].vehicle.cg_height == pytest.approx(0.5749))


def _outside(lo, hi):
    """A value just below ``lo`` and one just above ``hi`` (a tenth of the span beyond)."""
    return (("below", lo - 0.1 * (hi - lo)), ("above", hi + 0.1 * (hi - lo)))


def _registry_cases():
    from uqdrive.vehicle.effects import EFFECTS

    for i, (name, effect) in enumerate(EFFECTS.items()):
        inside = {p: 0.5 * (lo + hi) for p, (lo, hi) in zip(effect.parameters, effect.bounds)}
        for p, (lo, hi) in zip(effect.parameters, effect.bounds):
            for side, value in _outside(lo, hi):
                command = _commands[i % 3]
                refuse("model.yaml", f"registry_{name}_{p}_{side}[{command}]", with_model(model_file(_eff(**{name: {**inside, p: value}})), command),
                       rf"effect '{name}' parameter {p} = {value:g}.* is outside \[{lo:g}, {hi:g}\]")


_registry_cases()


def _load(expected_effects, **distributions):
    def check(value):
        structure, dist = value
        assert dict(structure.effects) == expected_effects
        for key, fields in distributions.items():
            assert dist[key] == fields
    return check


def load(make):
    from uqdrive.cli.model import load_model

    return lambda tmp, w: (lambda path: lambda: load_model(path, w.base))(make(tmp, w))


read("model.yaml", "effects_null_is_the_baseline", load(model_file(lambda d: d.update(effects=None))), _load({}))
read("model.yaml", "effects_empty_is_the_baseline", load(model_file(lambda d: d.update(effects={}))), _load({}))
read("model.yaml", "yaml_1_2_parameter", load(model_file(text=yaml.safe_dump(MODEL).replace("T: 0.05", "T: 5e-2"))),
     _load({"actuator_lag": (("T", 0.05),)}))
read("model.yaml", "integer_parameters", load(model_file(lambda d: d["distributions"]["F_w_mean"].update(low=-400, high=400))),
     _load({"actuator_lag": (("T", 0.05),)}, F_w_mean={"low": -400.0, "high": 400.0}))
read("model.yaml", "std_zero_is_known", load(model_file(_field("mu", std=0))), _load({"actuator_lag": (("T", 0.05),)}, mu={"mean": 1.0, "std": 0.0}))
read("model.yaml", "version_one_float", load(model_file(lambda d: d.update(uqdrive_model=1.0))), _load({"actuator_lag": (("T", 0.05),)}))
read("model.yaml", "three_parameter_effect", load(model_file(_eff(roll_steer={"K": 0.5, "f": 1.5, "zeta": 0.7}))),
     _load({"roll_steer": (("K", 0.5), ("f", 1.5), ("zeta", 0.7))}))
read("model.yaml", "lag_at_its_bound", load(model_file(_eff(actuator_lag={"T": 0}))), _load({"actuator_lag": (("T", 0.0),)}))
read("model.yaml", "m_load_reaches_identify", with_model(model_file(_dist("m_load", mean=80.0, std=10.0)), "identify"),
     lambda seen: (seen["settings"].uncertainty.m_load.mean, seen["settings"].uncertainty.m_load.std) == (80.0, 10.0))


# -- measured files: channel subsets, units, the speed over time ---------------------------------------
def dataset(edit, name="data.nc"):
    """The tiny ensemble edited by ``edit(ds)`` (which returns the dataset), written to ``name``."""
    def make(tmp, w):
        ds = edit(w.dataset())
        path = tmp / name
        ds.to_netcdf(path)
        return path
    return make


def with_data(make, command=identify, *extra):
    return lambda tmp, w: command(tmp, w, make(tmp, w), *extra)


def only(*channels):
    return lambda d: d.drop_vars([c for c in ("psi", "psi_dot", "beta", "y", "a_y") if c in d and c not in channels])


def units(name, unit):
    def edit(d):
        if unit is None:
            d[name].attrs.pop("units", None)
        else:
            d[name].attrs["units"] = unit
        return d
    return edit


def a_y(factor=1.0, unit="m/s^2", dtype="float64"):
    """a_y = v (beta_dot + psi_dot) of the runs, in ``unit`` (scaled by ``factor``)."""
    def edit(d):
        v = float(d.attrs["v_c"])
        ay = v * (np.gradient(d["beta"].values, d["time"].values, axis=1) + d["psi_dot"].values)
        d["a_y"] = (("sample", "time"), (ay * factor).astype(dtype), {} if unit is None else {"units": unit})
        return d
    return edit


def then(*edits):
    def edit(d):
        for e in edits:
            d = e(d)
        return d
    return edit


def speed(values, dims=("time",), unit="m/s", drop_v_c=False, v_c=None):
    def edit(d):
        shape = tuple(d.sizes.get(k, 7) for k in dims)
        d["v"] = (dims, np.broadcast_to(values(d) if callable(values) else values, shape).copy(), {} if unit is None else {"units": unit})
        if drop_v_c:
            d.attrs.pop("v_c")
        if v_c is not None:
            d.attrs["v_c"] = v_c
        return d
    return edit


def _channels(*expected):
    return lambda seen: seen["channels"] == expected if "channels" in seen and seen["command"] == "identify" else \
        tuple(c for c in ("psi", "psi_dot", "beta", "y", "a_y") if c in seen["ds"]) == expected


for _name, _edit, _expected in [
    ("yaw_rate_only", only("psi_dot"), ("psi_dot",)),
    ("imu_pair", then(a_y(), only("psi_dot", "a_y")), ("psi_dot", "a_y")),
    ("lateral_position_only", only("y"), ("y",)),
    ("no_side_slip", only("psi", "psi_dot", "y"), ("psi", "psi_dot", "y")),
    ("all_five", a_y(), ("psi", "psi_dot", "beta", "y", "a_y")),
    ("a_y_as_m_s2", then(a_y(unit="m/s2"), only("psi_dot", "a_y")), ("psi_dot", "a_y")),
    ("a_y_float32", then(a_y(dtype="float32"), only("psi_dot", "a_y")), ("psi_dot", "a_y")),
    ("extra_variables_kept", lambda d: d.assign(temperature=("time", np.full(d.sizes["time"], 20.0))), ("psi", "psi_dot", "beta", "y", "a_y")),
]:
    read("measured file", _name, with_data(dataset(_edit)), lambda seen, e=_expected: _channels(*e)(seen))
    if _name in ("imu_pair", "yaw_rate_only"):
        read("measured file", f"{_name}[discover]", with_data(dataset(_edit), discover), lambda seen, e=_expected: _channels(*e)(seen))


def _a_y_in_g(seen):
    ay = seen["ds"]["a_y"]
    assert ay.attrs["units"] == "m/s^2" and "a_y converted from g" in seen["ds"].attrs["conversions"]
    return float(np.abs(ay).max()) > 0.1


read("measured file", "a_y_in_g_is_converted", with_data(dataset(then(a_y(1 / 9.80665, unit="g"), only("psi_dot", "a_y")))), _a_y_in_g)
read("measured file", "delta_held_between_samples",
     lambda tmp, w: identify(tmp, w, dataset(lambda d: d.assign(delta=d["delta"].assign_attrs(interpolation="previous")))(tmp, w), "--model",
                             model_file()(tmp, w)), lambda seen: seen["command"] == "model")
read("measured file", "spun_flags_as_floats", with_data(dataset(lambda d: d.assign(spun=("sample", np.zeros(d.sizes["sample"]))))),
     lambda seen: int(seen["ds"]["spun"].sum()) == 0)

for _name, _edit, _pattern in [
    ("a_y_per_second_squared_words", a_y(unit="m/s/s"), r"variable 'a_y' has units 'm/s/s'; give the lateral acceleration in 'm/s\^2'"),
    ("a_y_without_units", a_y(unit=None), r"variable 'a_y' has units 'None'; give"),
    ("a_y_in_cm_s2", a_y(100.0), r"variable 'a_y' reaches .* beyond the physical 200 m/s\^2; check its units"),
    ("a_y_integer", a_y(dtype="int64"), r"variable 'a_y' has dtype int64; store it as floating point"),
    ("a_y_transposed", lambda d: a_y()(d).assign(a_y=lambda x: x["a_y"].T), r"variable 'a_y' has dims \('time', 'sample'\); expected"),
    ("a_y_nan", lambda d: a_y()(d).assign(a_y=lambda x: x["a_y"].where(x["time"] < 0.5)), r"variable 'a_y' holds \d+ NaN values; remove or interpolate"),
    ("psi_dot_in_deg_s", units("psi_dot", "deg/s"), r"variable 'psi_dot' has units 'deg/s'; expected 'rad/s' \(convert it"),
    ("psi_dot_without_units", units("psi_dot", None), r"variable 'psi_dot' has units 'None'; expected 'rad/s'"),
    ("y_in_km", units("y", "km"), r"variable 'y' has units 'km'; expected 'm'"),
    ("psi_in_degrees_scaled", lambda d: d.assign(psi=d["psi"] * 1e5), r"variable 'psi' reaches .* check its units"),
    ("no_channel", only(), r"no usable channel; give at least one of 'psi' \(rad\)"),
    ("capitalised_channels", lambda d: d.rename({"psi_dot": "Psi_dot", "psi": "Psi", "beta": "Beta", "y": "Y", "a_y": "A_y"}), r"no usable channel"),
    ("delta_in_degrees_unit", units("delta", "deg"), r"variable 'delta' has units 'deg'; expected 'rad'"),
    ("delta_without_units", units("delta", None), r"variable 'delta' has units 'None'; expected 'rad'"),
    ("delta_per_run", lambda d: d.assign(delta=d["delta"].expand_dims(sample=d.sizes["sample"])),
     r"variable 'delta' has dims \('sample', 'time'\); expected \('time',\)"),
    ("delta_cubic", lambda d: d.assign(delta=d["delta"].assign_attrs(interpolation="cubic")),
     r"variable 'delta' has interpolation 'cubic'; expected 'linear'"),
    ("delta_missing_with_subset", lambda d: only("psi_dot")(d).drop_vars("delta"), r"missing variable 'delta' \(rad\)"),
    ("time_descending", lambda d: d.assign_coords(time=d["time"].values[::-1].copy()), r"'time' must be a uniform, increasing grid; resample"),
    ("time_repeated", lambda d: d.assign_coords(time=np.r_[d["time"].values[:-1], d["time"].values[-2]]), r"'time' must be a uniform"),
    ("time_nan", lambda d: d.assign_coords(time=np.r_[np.nan, d["time"].values[1:]]), r"coordinate 'time' holds NaN or inf; give finite"),
    ("time_integer_ms", lambda d: d.assign_coords(time=("time", np.arange(d.sizes["time"]) * 20, {"units": "ms"})), r"'time' has units 'ms'; convert"),
    ("nine_runs", lambda d: d.isel(sample=slice(0, 9)), r"9 run\(s\).*identify needs at least 10.*record more runs"),
    ("spun_as_text", lambda d: d.assign(spun=("sample", np.array(["no"] * d.sizes["sample"]))), r"variable 'spun' must be one 0/1 flag per sample"),
    ("psi_dot_identical_runs", lambda d: d.assign(psi_dot=(("sample", "time"), np.repeat(d["psi_dot"].values[:1], d.sizes["sample"], 0),
                                                           {"units": "rad/s"})), r"variable 'psi_dot' is identical in every realisation"),
]:
    refuse("measured file", _name, with_data(dataset(_edit)), _pattern)
    if _name in ("a_y_in_cm_s2", "psi_dot_in_deg_s", "no_channel", "delta_cubic"):
        refuse("measured file", f"{_name}[discover]", with_data(dataset(_edit), discover), _pattern)

refuse("measured file", "dst_cost_on_a_subset", with_data(dataset(only("psi_dot")), identify, "--cost", "dst"),
       r"the DST cost compares the LST and NLST states.*channels psi_dot: use --cost std or inp")
refuse("measured file", "identify_model_without_all_states", lambda tmp, w: identify(tmp, w, dataset(only("psi_dot"))(tmp, w), "--model",
                                                                                      model_file()(tmp, w)),
       r"identify --model simulates all four states .* lacks psi, beta, y: identify it without --model")


# the speed: v, v_c, both, NaN, negative, wrong length -----------------------------------------------
def _speed_is(value):
    def check(seen):
        got = seen["v_c"] if seen["command"] == "model" else seen["settings"].vehicle.v_c
        return got == pytest.approx(value, rel=1e-12)
    return check


for _name, _edit, _value in [
    ("v_constant_without_v_c", speed(19.0, drop_v_c=True), 19.0),
    ("v_and_v_c_differ", speed(19.0, v_c=25.0), 19.0),
    ("v_and_v_c_agree", speed(19.0, v_c=19.0), 19.0),
    ("v_per_run_constant", speed(21.0, dims=("sample", "time"), drop_v_c=True), 21.0),
    ("v_c_integer", lambda d: d.assign_attrs(v_c=20), 20.0),
    ("v_c_float32", lambda d: d.assign_attrs(v_c=np.float32(20.5)), 20.5),
]:
    for _command in (("identify", identify), ("discover", discover)):
        read("speed", f"{_name}[{_command[0]}]", with_data(dataset(_edit), _command[1]), _speed_is(_value))
read("speed", "v_and_v_c_differ[identify --model]", lambda tmp, w: identify(tmp, w, dataset(speed(19.0, v_c=25.0))(tmp, w), "--model",
                                                                               model_file()(tmp, w)), _speed_is(19.0))
read("speed", "v_beside_a_v_c_word", with_data(dataset(speed(19.0, v_c="fast"))), _speed_is(19.0))
read("speed", "runs_at_different_constant_speeds", with_data(dataset(speed(lambda d: (18.0 + 0.2 * np.arange(d.sizes["sample"]))[:, None],
                                                                            dims=("sample", "time"), drop_v_c=True))),
     _speed_is(18.0 + 0.2 * 5.5))
refuse("speed", "runs_at_speeds_too_far_apart", with_data(dataset(speed(lambda d: (12.0 + 2.0 * np.arange(d.sizes["sample"]))[:, None],
                                                                            dims=("sample", "time"), drop_v_c=True))),
        r"runs' speeds depart from their mean by up to \d+ % \(at most 20 %.*store the runs of similar speed in one file each")


def _speed_note(tmp, w):
    from uqdrive.io import data_speed

    ds = speed(lambda d: (18.0 + 0.2 * np.arange(d.sizes["sample"]))[:, None], dims=("sample", "time"))(w.dataset())
    return lambda: data_speed(ds)


read("speed", "runs_at_different_constant_speeds_are_said", _speed_note,
     lambda got: got[0] == pytest.approx(19.1, rel=1e-12) and "differ (18-20.2 m/s): the model runs at their mean 19.1 m/s" in got[1]
     and "v_c = 19.4444 m/s is ignored" in got[1])
read("speed", "a_speed_profile", with_data(dataset(speed(lambda d: np.linspace(19.0, 17.0, d.sizes["time"]), drop_v_c=True))),
     lambda seen: seen["settings"].vehicle.v_c == pytest.approx(19.0))

for _name, _edit, _pattern in [
    ("v_nan", speed(lambda d: np.r_[np.nan, np.full(d.sizes["time"] - 1, 19.0)]), r"variable 'v' holds 1 NaN or infinite values; interpolate"),
    ("v_negative", speed(-19.0), r"variable 'v' reaches -19\.\.-19 m/s, outside 0\.5-100 m/s.*give \|v\| in m/s"),
    ("v_standstill", speed(lambda d: np.linspace(19.0, 0.0, d.sizes["time"])), r"variable 'v' reaches 0\.\.19 m/s.*no standstill"),
    ("v_in_km_h", speed(70.0, unit="km/h"), r"variable 'v' has units 'km/h'; give the speed in 'm/s' \(km/h / 3\.6\)"),
    ("v_without_units", speed(19.0, unit=None), r"variable 'v' has units 'None'; give the speed in 'm/s'"),
    ("v_too_fast", speed(170.0), r"variable 'v' reaches 170\.\.170 m/s, outside"),
    ("v_wrong_length", speed(19.0, dims=("t",)), r"variable 'v' has dims \('t',\); give the speed over \('time',\)"),
    ("v_per_run_only", speed(19.0, dims=("sample",)), r"variable 'v' has dims \('sample',\); give the speed over"),
    ("v_transposed", speed(19.0, dims=("time", "sample")), r"variable 'v' has dims \('time', 'sample'\)"),
    ("v_integer", speed(19, unit="m/s"), r"variable 'v' has dtype int64; store it as floating point"),
    ("v_c_bool", lambda d: d.assign_attrs(v_c=np.int8(1)).assign_attrs(v_c="true"), r"global attribute 'v_c' is 'true'; give one number"),
    ("v_c_in_km_h", lambda d: d.assign_attrs(v_c=252.0), r"global attribute 'v_c' = 252 m/s is outside the physical range 0\.5-100 m/s"),
    ("v_c_pair", lambda d: d.assign_attrs(v_c=np.array([19.4, 20.0])), r"global attribute 'v_c' is array\(\[19\.4, 20\. *\]\); give one number"),
    ("v_c_slow", lambda d: d.assign_attrs(v_c=0.4), r"global attribute 'v_c' = 0\.4 m/s is outside"),
]:
    refuse("speed", _name, with_data(dataset(_edit)), _pattern)
    if _name in ("v_nan", "v_negative", "v_in_km_h"):
        refuse("speed", f"{_name}[discover]", with_data(dataset(_edit), discover), _pattern)
refuse("speed", "profile[identify --model]", lambda tmp, w: identify(tmp, w, dataset(speed(lambda d: np.linspace(19.0, 17.0, d.sizes["time"])))(tmp, w),
                                                                      "--model", model_file()(tmp, w)),
       r"has a changing v: identify it without --model")


# -- output paths ------------------------------------------------------------------------------------
def read_only(tmp):
    """A folder this process cannot write in (as root chmod does not bind: the stub of os.access in `run` says so)."""
    folder = tmp / "ro"
    folder.mkdir()
    folder.chmod(0o555)
    return folder


def out(argv, path, *extra):
    argv = list(argv)
    argv[argv.index("--out") + 1] = str(path)
    return argv + list(extra)


def _existing(tmp, name, folder=False, files=()):
    path = tmp / name
    if folder:
        path.mkdir()
        for f in files:
            (path / f).write_text("old")
    else:
        path.write_text("my notes")
    return path


OUTPUTS = [
    ("simulate_into_missing_folder", lambda tmp, w: out(simulate(tmp, w), tmp / "a" / "x.nc"), r"output folder '.*a' does not exist; create it first"),
    ("simulate_onto_existing_file", lambda tmp, w: out(simulate(tmp, w), _existing(tmp, "x.nc")), r"output '.*x\.nc' exists; pass --force"),
    ("simulate_onto_a_folder", lambda tmp, w: out(simulate(tmp, w), _existing(tmp, "x.nc", True)), r"output path '.*x\.nc' is a directory; give a file name"),
    ("simulate_onto_a_folder_forced", lambda tmp, w: out(simulate(tmp, w), _existing(tmp, "x.nc", True), "--force"), r"is a directory; give a file name"),
    ("simulate_under_a_file", lambda tmp, w: out(simulate(tmp, w), _existing(tmp, "f") / "x.nc"), r"lies under a regular file.*choose another path"),
    ("simulate_empty_path", lambda tmp, w: out(simulate(tmp, w), ""), r"output path '\.' is a directory; give a file name"),
    ("simulate_read_only", lambda tmp, w: out(simulate(tmp, w), read_only(tmp) / "x.nc"), r"output folder '.*ro' is not writable; choose another path"),
    ("identify_onto_a_file", lambda tmp, w: out(identify(tmp, w), _existing(tmp, "est")), r"output folder '.*est' exists and is a regular file; choose"),
    ("identify_onto_a_file_forced", lambda tmp, w: out(identify(tmp, w), _existing(tmp, "est"), "--force"), r"is a regular file; choose another"),
    ("identify_over_an_estimate", lambda tmp, w: out(identify(tmp, w), _existing(tmp, "est", True, ["estimate.json"])),
     r"output '.*estimate\.json' exists; pass --force"),
    ("identify_over_a_figure", lambda tmp, w: out(identify(tmp, w), _existing(tmp, "est", True, ["fit.png"])), r"output '.*fit\.png' exists; pass --force"),
    ("identify_under_a_file", lambda tmp, w: out(identify(tmp, w), _existing(tmp, "f") / "a" / "est"), r"lies under a regular file.*choose another"),
    ("identify_read_only", lambda tmp, w: out(identify(tmp, w), read_only(tmp) / "est"), r"folder '.*ro' is not writable.*choose another path"),
    ("identify_model_read_only", lambda tmp, w: out(identify(tmp, w, None, "--model", model_file()(tmp, w)), read_only(tmp) / "est"),
     r"folder '.*ro' is not writable"),
    ("discover_onto_existing", lambda tmp, w: out(discover(tmp, w), _existing(tmp, "d", True)), r"output folder '.*d' exists; pass --force"),
    ("discover_onto_a_file", lambda tmp, w: out(discover(tmp, w), _existing(tmp, "d")), r"is an existing regular file, which is not replaced by a folder"),
    ("discover_onto_a_file_forced", lambda tmp, w: out(discover(tmp, w), _existing(tmp, "d"), "--force"), r"not replaced by a folder; choose another --out"),
    ("discover_under_a_file", lambda tmp, w: out(discover(tmp, w), _existing(tmp, "f") / "d"), r"lies under '.*f', which is not a folder; choose"),
    ("discover_read_only", lambda tmp, w: out(discover(tmp, w), read_only(tmp) / "d" / "e"), r"folder '.*ro' is not writable.*choose another --out"),
    ("discover_read_only_forced", lambda tmp, w: out(discover(tmp, w), read_only(tmp), "--force"), r"'.*ro' is not writable.*choose another --out"),
    ("discover_cwd", lambda tmp, w: out(discover(tmp, w), ""), r"output folder '\.' exists; pass --force"),
    ("config_dump_onto_existing", lambda tmp, w: ["config", "--dump", str(_existing(tmp, "c.yaml"))], r"output '.*c\.yaml' exists; pass --force"),
    ("config_dump_into_missing_folder", lambda tmp, w: ["config", "--dump", str(tmp / "a" / "c.yaml")], r"output folder '.*a' does not exist"),
    ("config_dump_onto_a_folder", lambda tmp, w: ["config", "--dump", str(_existing(tmp, "c", True)), "--force"], r"is a directory; give a file name"),
    ("import_onto_existing", lambda tmp, w: out(import_argv(tmp, w), _existing(tmp, "e.nc")), r"output '.*e\.nc' exists; pass --force"),
    ("import_read_only", lambda tmp, w: out(import_argv(tmp, w), read_only(tmp) / "e.nc"), r"output folder '.*ro' is not writable"),
    ("config_dump_read_only", lambda tmp, w: ["config", "--dump", str(read_only(tmp) / "c.yaml")], r"output folder '.*ro' is not writable"),
    ("import_into_missing_folder", lambda tmp, w: out(import_argv(tmp, w), tmp / "a" / "e.nc"), r"output folder '.*a' does not exist"),
]
for _name, _build, _pattern in OUTPUTS:
    refuse("output path", _name, _build, _pattern)

refuse("output path", "discover_forced_over_the_users_files", lambda tmp, w: out(discover(tmp, w), _existing(tmp, "d", True, ["verdict.json", "notes.txt"]),
                                                                                 "--force"), r"output folder '.*d' holds 'notes\.txt', which is no output")
read("output path", "identify_nested_missing_folders", lambda tmp, w: out(identify(tmp, w), tmp / "a" / "b" / "est"), lambda seen: True)
read("output path", "identify_over_an_estimate_forced", lambda tmp, w: out(identify(tmp, w), _existing(tmp, "est", True, ["estimate.json"]), "--force"),
     lambda seen: True)
read("output path", "discover_nested_missing_folders", lambda tmp, w: out(discover(tmp, w), tmp / "a" / "b" / "d"), lambda seen: True)
read("output path", "discover_over_a_verdict_forced", lambda tmp, w: out(discover(tmp, w), _existing(tmp, "d", True, ["verdict.json"]), "--force"),
     lambda seen: True)
read("output path", "simulate_onto_existing_forced", lambda tmp, w: out(simulate(tmp, w), _existing(tmp, "x.nc"), "--force"), lambda seen: True)


# -- YAML numbers, duplicated keys, configs ------------------------------------------------------------
def _tiny_text(old, new, count=1):
    return lambda w: yaml.safe_dump(tiny_config()).replace(old, new, count)


for _name, _text, _check in [
    ("m_base_exponent", _tiny_text("m_base: 1784.0", "m_base: 1.784e3"), lambda s: s.vehicle.m_base == 1784.0),
    ("dt_exponent", _tiny_text("dt: 0.02", "dt: 2e-2"), None),
    ("leading_dot", _tiny_text("mean: 1.0", "mean: .9"), lambda s: s.uncertainty.mu.mean == 0.9),
    ("signed_exponent", _tiny_text("low: -400.0", "low: -4.0E+2"), lambda s: s.uncertainty.F_w_mean.low == -400.0),
    ("integer_mass", _tiny_text("m_base: 1784.0", "m_base: 1784"), lambda s: s.vehicle.m_base == 1784.0),
    ("anchor_and_alias", _tiny_text("mu:", "mu: &friction", 1), lambda s: s.uncertainty.mu.mean == 1.0),
]:
    read("config", _name, with_config(config_file(text=_text)),
         (lambda seen, c=_check: c is None or c(seen["settings"])))

for _name, _text, _pattern in [
    ("duplicated_section", lambda w: yaml.safe_dump(tiny_config()) + "seed: 7\n", r"key 'seed' is given twice \(lines \d+ and \d+\); keep one"),
    ("duplicated_nested", _tiny_text("  m_base: 1784.0\n", "  m_base: 1784.0\n  m_base: 1.784\n"), r"key 'm_base' is given twice"),
    ("not_a_number_word", _tiny_text("m_base: 1784.0", "m_base: heavy"), r"config key 'vehicle\.m_base' \(kg\): 'heavy'.*write a plain number"),
    ("number_with_unit", _tiny_text("dt: 0.02", "dt: 20 ms"), r"config key 'time\.dt'.*'20 ms'.*write a plain number"),
    ("comma_decimal", _tiny_text("m_base: 1784.0", "m_base: 1784,5"), r"config key 'vehicle\.m_base'.*plain number"),
    ("seed_fraction", _tiny_text("seed: ", "seed: 1.5 #"), r"config key 'seed'.*integer"),
    ("spin_policy_word", _tiny_text("spin_policy: exclude", "spin_policy: drop"), r"config key 'montecarlo\.spin_policy'.*choose one of keep, exclude"),
    ("tyre_E_above_one", _tiny_text("tyre:\n  C: 1.9\n  E: 0.97", "tyre:\n  C: 1.9\n  E: 1.5"), r"config key 'tyre\.E'.*<= 1"),
    ("gravity_zero", _tiny_text("g: 9.81", "g: 0"), r"config key 'vehicle\.g'.*> 0"),
    ("dt_not_dividing", _tiny_text("dt: 0.02", "dt: 0.03"), r"config key 'time\.dt' = 0\.03 must divide"),
    ("unknown_top_level", lambda w: yaml.safe_dump(tiny_config()) + "vehicles: thesis\n", r"config key 'vehicles' is not known; allowed keys"),
    ("yes_for_a_number", _tiny_text("m_base: 1784.0", "m_base: yes"), r"config key 'vehicle\.m_base'.*(number|boolean)"),
    ("tabs", lambda w: "seed: 1\nvehicle:\n\tm_base: 1\n", r"config file '.*config\.yaml' is not valid YAML"),
    ("a_number", lambda w: "12\n", r"config file '.*config\.yaml' must hold a mapping of keys"),
    ("l_f_beyond_wheelbase", lambda w: yaml.safe_dump({**tiny_config(), "uncertainty": {**tiny_config()["uncertainty"], "l_f": {"mean": 3.55, "std": 0.2}}}),
     r"uncertainty\.l_f\.mean' = 3\.55 must lie inside \(0, vehicle\.wheelbase"),
]:
    refuse("config", _name, with_config(config_file(text=_text), simulate if "seed" in _name else identify), _pattern)
refuse("config", "candidates_unknown", with_config(config_file(lambda c: c["discrepancy"].update(candidates=["turbo"])), discover), r"turbo")
refuse("config", "candidates_word", with_config(config_file(lambda c: c["discrepancy"].update(candidates="every")), discover),
       r"config key 'discrepancy\.candidates': 'every' .*; give 'all' or a list of all, tyre_saturation")
refuse("config", "posterior_effect_unknown", with_config(config_file(lambda c: c["discrepancy"]["posterior"].update(effects=["turbo"])), discover),
       r"turbo")
refuse("config", "optimiser_unknown", with_config(config_file(lambda c: c["identification"].update(optimiser="adam"))), r"identification\.optimiser")
refuse("config", "state_scale_unknown", with_config(config_file(lambda c: c["identification"].update(state_scale="si"))), r"identification\.state_scale")


def _ranges():
    """Every physical range of the config (config.PHYSICAL_RANGES), missed on each side."""
    from uqdrive.config import PHYSICAL_RANGES

    for key, (lo, hi, lo_in, hi_in, unit) in PHYSICAL_RANGES.items():
        for side, value in (("below", lo - (1 if lo_in else 0)), ("above", hi * 2 + 1)):
            if key == "uncertainty.l_f.std" and side == "above":
                continue  # a 41 m std of l_f is refused too, by the l_f mean's range first
            value = int(value) if isinstance(lo, int) and isinstance(hi, int) else float(value)

            def edit(c, key=key, value=value):
                *parents, leaf = key.split(".")
                node = c
                for part in parents:
                    node = node[part]
                node[leaf] = value
            refuse("config", f"range_{key}_{side}", with_config(config_file(edit), simulate), rf"config key '{re.escape(key)}'")


_ranges()


def _ramp(**ramp):
    return with_config(config_file(lambda c: c["montecarlo"].update(speed_profile=ramp)), simulate)


refuse("config", "ramp_to_standstill", _ramp(start_kmh=70.0, end_kmh=0.5, duration=0.5),
       r"config key 'montecarlo\.speed_profile\.end_kmh' = 0\.5 km/h is outside \[1\.8, 360\] km/h; give a forward speed")
refuse("config", "ramp_in_m_s_too_fast", _ramp(start_kmh=500.0, end_kmh=300.0, duration=0.5), r"speed_profile\.start_kmh' = 500 km/h is outside")
refuse("config", "ramp_after_the_run", _ramp(start_kmh=70.0, end_kmh=50.0, duration=0.5, t_start=5.0),
       r"speed_profile\.t_start' = 5 s is not before time\.t_end = 0\.8 s.*give an earlier start")
refuse("config", "ramp_without_duration", _ramp(start_kmh=70.0, end_kmh=50.0), r"speed_profile\.duration' is missing")
read("config", "ramp_braking", _ramp(start_kmh=70.0, end_kmh=50.0, duration=0.5),
     lambda seen: (seen["settings"].speed.start_kmh, seen["settings"].speed.end_kmh, seen["settings"].speed.duration) == (70.0, 50.0, 0.5))
refuse("config", "missing_config_file", lambda tmp, w: out(identify(tmp, w), tmp / "o") + ["--config", str(tmp / "nosuch.yaml")],
       r"cannot read config file '.*nosuch\.yaml': No such file")
refuse("config", "config_is_a_folder", lambda tmp, w: identify(tmp, w) + ["--config", str(_existing(tmp, "cfg", True))], r"cannot read config file '.*cfg'")
refuse("config", "check_duplicated", lambda tmp, w: ["config", "--check", str(write(tmp / "c.yaml", yaml.safe_dump(tiny_config()) + "seed: 1\n"))],
       r"key 'seed' is given twice")
read("config", "check_yaml_1_2", lambda tmp, w: ["config", "--check", str(write(tmp / "c.yaml", _tiny_text("dt: 0.02", "dt: 2e-2")(w)))],
     lambda seen: seen == 0)
read("config", "samples_exponent", with_config(config_file(text=_tiny_text("  samples: 12\n  spin_policy", "  samples: 1.2e1\n  spin_policy")), simulate),
     lambda seen: seen["settings"].samples == 12 and isinstance(seen["settings"].samples, int))


# -- flags of identify and discover ---------------------------------------------------------------------
for _name, _build, _pattern in [
    ("candidates_unknown", lambda tmp, w: discover(tmp, w, None, "--candidates", "turbo"), r"turbo"),
    ("candidates_empty", lambda tmp, w: discover(tmp, w, None, "--candidates", ","), r"--candidates names no candidate"),
    ("m_load_in_tonnes_huge", lambda tmp, w: identify(tmp, w, None, "--m-load", "1e6"), r"--m-load 1e6 is outside \[0, 100000\] kg"),
    ("cost_unknown", lambda tmp, w: identify(tmp, w, None, "--cost", "l2"), r"--cost 'l2' is unknown; choose one of std, inp, dst"),
    ("steer_unknown", lambda tmp, w: simulate(tmp, w, "--steer", "left"), r"argument --steer: invalid choice: 'left'"),
    ("device_unknown", lambda tmp, w: simulate(tmp, w, "--device", "tpu"), r"argument --device: invalid choice: 'tpu'"),
    ("samples_exponent", lambda tmp, w: simulate(tmp, w, "--samples", "1e3"), r"--samples '1e3' is not an integer; give one in 2\.\.10000000"),
]:
    refuse("flags", _name, _build, _pattern)


# -- config overrides (the workflow's --config key=value) ---------------------------------------------
def overrides(*entries, files=()):
    from uqdrive.workflow_config import workflow_config

    def build(tmp, w):
        paths = [write(tmp / f"extra{i}.yaml", t) for i, t in enumerate(files)]
        return lambda: workflow_config(w.config, paths, list(entries))
    return build


for _name, _entries, _files, _pattern in [
    ("no_equals", ["seed"], (), r"config override 'seed' must read key=value"),
    ("no_key", ["=5"], (), r"config override '=5' must read key=value"),
    ("word_for_a_number", ["seed=abc"], (), r"config key 'seed'.*integer"),
    ("misspelt_key", ["vehicle.m_bse=1"], (), r"config key 'vehicle\.m_bse' is not known"),
    ("nested_word", ['control={"R": "fifty"}'], (), r"config key 'control\.R'.*number"),
    ("not_yaml", ["time.dt=[1"], (), r"config override 'time\.dt': the value is not YAML"),
    ("nan", ["montecarlo.samples=.nan"], (), r"config key 'montecarlo\.samples' is nan; give a finite number"),
    ("duplicated_in_value", ["vehicle={m_base: 1, m_base: 2}"], (), r"key 'm_base' is given twice"),
    ("vehicle_file_missing", ["vehicle_file=nosuch.yaml"], (), r"cannot read vehicle file 'nosuch\.yaml'"),
    ("tonnes", ["vehicle.m_base=1.784"], (), r"vehicle\.m_base' = 1\.784 kg is not a car's.*tonnes\?"),
    ("configfile_duplicated", [], ("seed: 1\nseed: 2\n",), r"key 'seed' is given twice"),
    ("configfile_a_list", [], ("- 1\n",), r"config file '.*extra0\.yaml' must hold a mapping of keys"),
]:
    CASES.append(Case(_name, "config override", overrides(*_entries, files=_files), "refused", _pattern))
read("config override", "exponent", overrides("vehicle.m_base=1.784e3"), lambda cfg: cfg["vehicle"]["m_base"] == 1784.0)
read("config override", "last_wins", overrides("seed=1", "seed=2"), lambda cfg: cfg["seed"] == 2)
read("config override", "packaged_vehicle", overrides("vehicle_file=thesis"), lambda cfg: cfg["vehicle"]["name"] == "thesis")
read("config override", "configfile_exponent", overrides(files=("vehicle:\n  m_base: 1.5e3\n",)), lambda cfg: cfg["vehicle"]["m_base"] == 1500.0)


# -- uqdrive import -----------------------------------------------------------------------------------
def import_argv(tmp, w, cmap=None, runs=None, *extra):
    cmap = write(tmp / "map.yaml", CHANNEL_MAP if cmap is None else cmap)
    runs = runs if runs is not None else [w.folder / f"run{i}.csv" for i in range(10)]
    return ["import", *map(str, runs), "--channels", str(cmap), "--out", str(tmp / "e.nc"), *map(str, extra)]


def with_map(**changes):
    def build(tmp, w):
        cmap = copy.deepcopy(CHANNEL_MAP)
        for key, value in changes.items():
            if value is None:
                cmap.pop(key)
            else:
                cmap[key] = value
        return import_argv(tmp, w, cmap)
    return build


for _name, _build, _pattern in [
    ("map_unknown_variable", with_map(speed={"channel": "Speed", "units": "km/h"}), r"'speed' is no schema variable; map any of"),
    ("map_without_delta", with_map(delta=None), r"has no entry 'delta'; map the steering angle's channel"),
    ("map_without_v", with_map(v=None), r"has no entry 'v'; map the vehicle speed's channel"),
    ("map_no_measured_channel", with_map(psi_dot=None, a_y=None), r"maps no measured channel; map at least one of"),
    ("map_entry_a_name", with_map(psi_dot="YawRate"), r"entry 'psi_dot'.* is 'YawRate'; write it as \{channel: NAME, units: UNIT\}"),
    ("map_entry_misspelt_key", with_map(psi_dot={"channel": "YawRate", "unit": "deg/s"}), r"entry 'psi_dot'.*unknown key 'unit'"),
    ("map_entry_without_channel", with_map(psi_dot={"units": "deg/s"}), r"entry 'psi_dot'.*has no channel name; give 'channel: NAME'"),
    ("map_unit_unknown", with_map(psi_dot={"channel": "YawRate", "units": "degs"}), r"entry 'psi_dot' \(channel 'YawRate'\): unit 'degs' (is not a unit|has the dimension).*give a unit of psi_dot's dimension"),
    ("map_unit_wrong_dimension", with_map(v={"channel": "Speed", "units": "m/s^2"}), r"entry 'v' \(channel 'Speed'\): unit 'm/s\^2' has the dimension"),
    ("map_sign_two", with_map(a_y={"channel": "LatAcc", "units": "g", "sign": 2}), r"entry 'a_y'.*sign is 2; give 1 or -1"),
    ("map_sign_word", with_map(a_y={"channel": "LatAcc", "units": "g", "sign": "minus"}), r"entry 'a_y'.*sign.*'minus'"),
    ("map_ratio_zero", with_map(delta={"channel": "Steer", "units": "deg", "steering_ratio": 0}), r"steering_ratio is 0; give the hand-wheel angle"),
    ("map_ratio_on_yaw_rate", with_map(psi_dot={"channel": "YawRate", "units": "deg/s", "steering_ratio": 15.0}),
     r"steering_ratio belongs to the steering entry 'delta' only; remove it"),
    ("map_a_list", lambda tmp, w: import_argv(tmp, w, [CHANNEL_MAP]), r"channel map '.*map\.yaml' must hold a mapping"),
    ("map_duplicated", lambda tmp, w: out(import_argv(tmp, w), tmp / "e.nc")[:11] + ["--channels", str(write(tmp / "m2.yaml", yaml.safe_dump(
        CHANNEL_MAP) + "v: {channel: Speed, units: m/s}\n")), "--out", str(tmp / "e.nc")], r"channel map '.*m2\.yaml' is not valid YAML.*given twice"),
    ("map_missing", lambda tmp, w: import_argv(tmp, w)[:11] + ["--channels", str(tmp / "nosuch.yaml"), "--out", str(tmp / "e.nc")],
     r"cannot read channel map '.*nosuch\.yaml'.*give the path of MAP\.yaml"),
    ("map_channel_not_in_file", with_map(psi_dot={"channel": "Yaw_Rate", "units": "deg/s"}), r"channel 'Yaw_Rate' \(mapped to psi_dot\) is not in the header"),
    ("map_time_not_in_file", with_map(time={"channel": "time", "units": "s"}), r"channel 'time' \(the time column\) is not in the header"),
    ("run_missing", lambda tmp, w: import_argv(tmp, w, None, [w.folder / f"run{i}.csv" for i in range(9)] + [tmp / "run9.csv"]),
     r"recording '.*run9\.csv' does not exist or is not a file"),
    ("run_suffix", lambda tmp, w: import_argv(tmp, w, None, [w.folder / f"run{i}.csv" for i in range(9)] + [write(tmp / "run9.txt", "x")]),
     r"recording '.*run9\.txt' has the suffix '\.txt'; give MDF4"),
    ("run_twice", lambda tmp, w: import_argv(tmp, w, None, [w.folder / f"run{i}.csv" for i in range(9)] + [w.folder / "run0.csv"]),
     r"recording '.*run0\.csv' is given twice"),
    ("nine_runs", lambda tmp, w: import_argv(tmp, w, None, [w.folder / f"run{i}.csv" for i in range(9)]), r"9 run\(s\).*record more runs"),
    ("run_header_only", lambda tmp, w: import_argv(tmp, w, None, [w.folder / f"run{i}.csv" for i in range(9)] + [write(tmp / "r.csv", "t_ms,YawRate\n")]),
     r"r\.csv: a CSV recording needs a header row of channel names and data rows"),
    ("run_text_cell", lambda tmp, w: import_argv(tmp, w, None, [w.folder / f"run{i}.csv" for i in range(9)] + [write(
        tmp / "r.csv", (w.folder / "run9.csv").read_text().replace(",72.9\n", ",n/a\n", 1))]), r"channel 'Speed' holds 'n/a' in data row 1, not a number"),
    ("dt_zero", lambda tmp, w: import_argv(tmp, w, None, None, "--dt", "0"), r"--dt 0 is outside"),
    ("dt_nan", lambda tmp, w: import_argv(tmp, w, None, None, "--dt", "nan"), r"--dt nan is outside"),
    ("align_unknown", lambda tmp, w: import_argv(tmp, w, None, None, "--align", "yaw"), r"argument --align: invalid choice: 'yaw'"),
    ("deviation_negative", lambda tmp, w: import_argv(tmp, w, None, None, "--max-steer-deviation", "-1"), r"--max-steer-deviation -1 is outside"),
    ("vehicle_unknown", lambda tmp, w: import_argv(tmp, w, None, None, "--vehicle", "golf"), r"unknown vehicle 'golf'"),
]:
    refuse("import", _name, _build, _pattern)


def _factors(**expected):
    def check(seen):
        entries = seen["cmap"].entries
        return all(entries[k].factor == pytest.approx(v, rel=1e-12) for k, v in expected.items())
    return check


read("import", "units_converted", lambda tmp, w: import_argv(tmp, w), _factors(psi_dot=math.pi / 180, a_y=9.80665, v=1 / 3.6,
                                                                                  delta=math.pi / 180 / 15.0))
read("import", "ratio_from_the_vehicle_file",
     lambda tmp, w: out(with_map(delta={"channel": "Steer", "units": "deg"})(tmp, w), tmp / "e.nc", "--vehicle", car({"steering_ratio": 16.0})(tmp, w)),
     _factors(delta=math.pi / 180 / 16.0))
read("import", "map_exponent_ratio", with_map(delta={"channel": "Steer", "units": "deg", "steering_ratio": 1.5e1}), _factors(delta=math.pi / 180 / 15.0))


# -- sweep files ------------------------------------------------------------------------------------
def sweep(text):
    from uqdrive.studies.sweep import load_sweep

    def build(tmp, w):
        write(tmp / "base.yaml", tiny_config())
        path = write(tmp / "s.yaml", "base: base.yaml\n" + text)
        return lambda: load_sweep(path, search=[tmp])
    return build


for _name, _text, _pattern in [
    ("grid_scalar", "grid: {wind.sigma: 100}\ncollect: [kl]\n", r"'grid\.wind\.sigma' must be a non-empty list of values"),
    ("grid_empty_list", "grid: {wind.sigma: []}\ncollect: [kl]\n", r"'grid\.wind\.sigma' must be a non-empty list"),
    ("grid_nested", "grid: {wind: {sigma: [1, 2]}}\ncollect: [kl]\n", r"'grid\.wind' must be a non-empty list"),
    ("grid_empty", "grid: {}\ncollect: [kl]\n", r"'grid' names no key; give at least one dotted key"),
    ("zip_unequal", "zip: {wind.sigma: [1, 2], wind.Tc: [1]}\ncollect: [kl]\n", r"'zip' lists must have equal lengths"),
    ("set_unknown_key", "set: {wind.sigmaa: 1}\ngrid: {wind.sigma: [1]}\ncollect: [kl]\n", r"wind\.sigmaa"),
    ("set_bad_value", "set: {wind.sigma: -1}\ngrid: {wind.Tc: [1]}\ncollect: [kl]\n", r"config key 'wind\.sigma'.*>= 0"),
    ("swept_and_set", "set: {wind.sigma: 1}\ngrid: {wind.sigma: [1]}\ncollect: [kl]\n", r"wind\.sigma both swept and set"),
    ("collect_unknown_word", "grid: {wind.sigma: [1]}\ncollect: spins\n", r"unknown collector\(s\) spins; choose from"),
    ("collect_missing", "grid: {wind.sigma: [1]}\n", r"'collect' must list the metric groups"),
    ("duplicated_key", "grid: {wind.sigma: [1]}\ncollect: [kl]\ncollect: [kl]\n", r"is not valid YAML.*key 'collect' is given twice"),
    ("not_yaml", "grid: [\n", r"sweep file '.*s\.yaml' is not valid YAML"),
    ("base_missing", "grid: {wind.sigma: [1]}\ncollect: [kl]\nbase: none.yaml\n", r"is not valid YAML.*key 'base' is given twice"),
    ("point_value_word", "grid: {time.dt: [0.02, fast]}\ncollect: [kl]\n", r"point p01_dt=fast: config key 'time\.dt'"),
]:
    CASES.append(Case(_name, "sweep", sweep(_text), "refused", _pattern))
read("sweep", "exponent_values", sweep("grid: {wind.sigma: [1e2, 2.5e2]}\ncollect: [kl, kl]\n"),
     lambda s: [p.values["wind.sigma"] for p in s.points] == [100.0, 250.0] and s.collect == ("kl",))


# -- the runner ---------------------------------------------------------------------------------------
def _one_line(text: str) -> str:
    assert text.count("\n") == 1 and text.endswith("\n"), text
    assert "Traceback" not in text, text
    return text


def run(case: Case, tmp: Path, w: World, capsys, monkeypatch):
    """(outcome, what, created) of a case: ("refused", the line), ("read", what the core got or the
    call's value) or ("other", a description: a traceback, another exit status), and the paths
    the command created under ``tmp`` (its inputs, made first, excluded)."""
    real = os.access
    monkeypatch.setattr(os, "access", lambda p, mode, **k: False if Path(p).name == "ro" and mode & os.W_OK else real(p, mode, **k))
    built = case.build(tmp, w)
    before = files_under(tmp)
    capsys.readouterr()
    if callable(built):
        try:
            value = built()
        except (ConfigError, DataError, SweepError) as exc:
            return "refused", str(exc) + "\n", files_under(tmp) - before
        return "read", value, files_under(tmp) - before
    try:
        rc = main([str(a) for a in built])
    except Reached as reached:
        return "read", reached.seen, files_under(tmp) - before
    except BaseException as exc:  # noqa: BLE001 - anything else is the finding
        return "other", f"{type(exc).__name__}: {exc}", files_under(tmp) - before
    captured = capsys.readouterr()
    err = captured.err
    if rc == 2 and not captured.out:
        return "refused", err, files_under(tmp) - before
    if rc == 0 and case.interface == "config":
        return "read", rc, files_under(tmp) - before
    return "other", f"exit {rc}: {err}", files_under(tmp) - before


@pytest.mark.parametrize("case", CASES, ids=[f"{c.interface}:{c.name}" for c in CASES])
def test_bad_input_is_refused_cleanly_or_read_right(case, world, tmp_path, capsys, monkeypatch, stubs):
    outcome, what, created = run(case, tmp_path, world, capsys, monkeypatch)
    assert outcome == case.expect, f"{case.interface}: {case.name}: {outcome}: {what}"
    if outcome == "refused":
        line = _one_line(what)
        assert re.search(case.pattern, line), line
        assert FIX.search(line), f"no fix in: {line}"
    else:
        assert case.check(what) is not False, what
    assert not created, created


def test_the_battery_counts_its_cases():
    """At least 200 distinct inputs, refused or read right, on every interface."""
    names = [(c.interface, c.name) for c in CASES]
    assert len(set(names)) == len(names) >= 200
    by = {}
    for c in CASES:
        by.setdefault(c.interface, {"refused": 0, "read": 0})[c.expect] += 1
    assert set(by) >= {"vehicle file", "model.yaml", "measured file", "speed", "output path", "config", "config override", "import", "sweep"}

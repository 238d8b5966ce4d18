"""The four-wheel benchmark's record and judgement: every registered effect is either in the
reality or not, the car's values of the candidates' parameters follow from its constants, each
branch of the judgement fails the wrong verdict, and the committed record renders as judged."""

import importlib.util
import json
import math
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.append(str(ROOT / "benchmarks"))  # the scripts import their shared judgement by name, as when they run
_spec = importlib.util.spec_from_file_location("bench_four_wheel", ROOT / "benchmarks" / "bench_four_wheel.py")
bench = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(bench)


def test_every_registered_effect_is_either_in_the_four_wheel_reality_or_not():
    from uqdrive.vehicle import effects as fx

    family_of = {m: fam for fam, members in fx.FAMILIES.items() for m in members}
    registered = {family_of.get(name, name) for name in fx.EFFECTS}
    assert not set(bench.PRESENT) & set(bench.ABSENT)
    assert registered == (set(bench.PRESENT) | set(bench.ABSENT)) - {"unrecognised"}


def test_the_cars_values_follow_from_its_constants():
    from dataclasses import asdict

    from uqdrive.vehicle.four_wheel import FourWheelCar

    values = bench.car_values(asdict(FourWheelCar()), m_load=100.0)
    # roll-stiffness share 80 / (80 + 60) kN m/rad; the steady roll per g of the base mass' force
    # h m_base g / (K_phi - m g h) = 0.55 * 1784 * 9.81 / (140e3 - 1884 * 9.81 * 0.55) = 0.074137 rad, times e_f 0.08;
    # K_y's slope at the static load with q_Ky 2: cos(0.9273) * 0.8 / sin(0.9273) = 0.6, so q = -0.4.
    # Worked by hand to 5 digits: 1e-4 relative.
    assert values["lateral_load_transfer"]["chi_f"] == pytest.approx(80 / 140, rel=1e-4)
    assert values["compliance_steer"]["K"] == pytest.approx(math.degrees(0.08 * 0.074137), rel=1e-4)
    assert values["load_sensitive_tyre"]["q"] == pytest.approx(-0.4, rel=1e-4)
    # roll mode: sqrt(129835 / (550 + 1884 * 0.3025)) / 2 pi = 1.7137 Hz, damping 10.5e3 / (2 sqrt(129835 * 1119.9))
    assert values["roll_steer"]["f"] == pytest.approx(1.7137, rel=1e-4)
    assert values["roll_steer"]["zeta"] == pytest.approx(10.5e3 / (2 * math.sqrt(129834.9 * 1119.91)), rel=1e-4)
    assert values["tyre_relaxation"]["sigma"] == 0.4 and values["longitudinal_load_transfer"]["h"] == 0.55


def _row(named, before, after, best=None):
    return {"effects": [{"effect": n} for n in named], "gap_before": before, "gap_after": after, "best": best or {}}


@pytest.mark.parametrize("row, judged", [
    # the reality has a track: its lateral load transfer is physical here (not in the real-tyres sedan)
    (_row(["lateral_kinematics", "lateral_load_transfer", "unrecognised"], 5.0, 3.0, {"effect": "tyre_saturation", "share_closed": 0.7}),
     "physical (`tyre_saturation` alone closes 0.70 of the chi2 excess)"),
    (_row(["roll_steer", "wind_gust"], 5.0, 1.0), "names wind_gust, absent from the reality"),
    (_row(["sensor_bias_psi"], 5.0, 1.0), "names sensor_bias_psi, absent from the reality"),
    (_row(["actuator_lag"], 5.0, 1.0), "names actuator_lag, absent from the reality"),
    (_row(["unrecognised"], 5.0, 5.0, {"effect": "tyre_relaxation", "share_closed": 0.62}), "`unrecognised` alone, gap unchanged"),
    (_row(["unrecognised"], 5.0, 5.0, {"effect": "tyre_relaxation", "share_closed": 0.31}),
     "physical: `unrecognised`, no candidate closes half the chi2 excess (`tyre_relaxation` 0.31)"),
    (_row(["tyre_saturation"], 5.0, 3.0), "gap not halved"),
])
def test_each_branch_of_the_judgement_fails_the_wrong_verdict(row, judged):
    assert bench.judge(row) == judged


def test_the_committed_record_renders_as_judged():
    rows = json.loads((ROOT / "docs" / "four_wheel.json").read_text())
    text = bench.table(rows)
    assert text.count("\n") == len(rows) + 1  # header, rule, one line per case
    for r in rows:
        assert r["name"] in text and r["expected"] == bench.EXPECTED[r["name"]]
        if "error" not in r:
            assert bench.judge(r) == r["judged"] and f"{r['cpu_seconds']:.0f} s" in text

"""The real-tyres benchmark's judgement of a verdict row: a named effect absent from the car is
wrong, `unrecognised` alone is physical only where no candidate closes half the chi2 excess, and
a physical row gives the best candidate's share."""

import importlib.util
import sys
from pathlib import Path

import pytest

sys.path.append(str(Path(__file__).resolve().parents[1] / "benchmarks"))  # the scripts import their shared judgement by name
_spec = importlib.util.spec_from_file_location("bench_real_tyres", Path(__file__).resolve().parents[1] / "benchmarks" / "bench_real_tyres.py")
bench = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(bench)


def _row(named, before, after, car="roll_steering", best=None):
    return {"effects": [{"effect": n} for n in named], "gap_before": before, "gap_after": after, "car": car, "best": best or {}}


@pytest.mark.parametrize("row, judged", [
    (_row(["roll_steer", "unrecognised"], 6.8, 2.4, best={"effect": "roll_steer", "share_closed": 0.83}),
     "physical (`roll_steer` alone closes 0.83 of the chi2 excess)"),
    (_row(["roll_steer"], 6.8, 2.4, car="sedan"), "names roll_steer, absent from the reality"),
    (_row(["unrecognised"], 2.7, 2.7, best={"effect": "tyre_shape", "share_closed": 0.31}),
     "physical: `unrecognised`, no candidate closes half the chi2 excess (`tyre_shape` 0.31)"),
    (_row(["unrecognised"], 2.7, 2.7, best={"effect": "roll_steer", "share_closed": 0.6}), "`unrecognised` alone, gap unchanged"),
    (_row(["tyre_saturation"], 4.0, 3.0, car="sedan"), "gap not halved"),
])
def test_judge_reads_the_named_set_the_gap_and_the_best_candidates_share(row, judged):
    assert bench.judge(row) == judged

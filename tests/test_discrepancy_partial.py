"""The partial truth kept: a candidate that closes half of the chi2 excess is named with the rest
`unrecognised` after it, and an effect whose parameter has one physical value (the exact course
angle, k = 1) is judged at that value, a free fit's departure reported beside it."""

import copy
from types import SimpleNamespace

import numpy as np
import pytest

from uqdrive.inference.discrepancy import DiscrepancyFinder
from uqdrive.inference.discrepancy.effectset import EffectSet
from uqdrive.inference.discrepancy.acceptance import PARTIAL_SHARE, acceptance
from uqdrive.inference.discrepancy.comparison import ModelComparison
from uqdrive.settings import Settings
from uqdrive.studies.hidden_effects import HiddenEffectCase, generate
from uqdrive.vehicle.effects import EFFECTS, PHYSICAL, VANISHES

CELLS = (2, 4, 10)  # 80 standardised residuals


class _Band(SimpleNamespace):
    """A null band of mean z^2 1 per cell, chi2 sd 10 and a scan threshold 3."""

    def __init__(self):
        super().__init__(mean_square_null=1.0, chi2_null_sd=10.0, inflation=1.0, threshold=3.0)

    def max_statistic(self, z):
        return float(np.abs(z).max())


def _fit(chi2, peak=5.0):
    """A linear-footing fit of total chi2 ``chi2`` spread evenly over the cells, one cell at ``peak``."""
    z = np.full(CELLS, np.sqrt(max(chi2 - peak**2, 0.0) / (np.prod(CELLS) - 1)))
    z.flat[0] = peak
    return SimpleNamespace(z_=z, chi2_=float(np.sum(z**2)), scale_=np.ones(CELLS), structure_=None)


def test_a_set_closing_half_the_excess_is_kept_as_partial_and_a_smaller_share_is_not():
    """Null level 80, base chi2 1080: excess 1000. A final chi2 of 480 (excess 400, 60 % closed)
    leaves an RMS gap of sqrt(400/80) = 2.24 of sqrt(1000/80) = 3.54, more than half: the halving
    rule alone rejects it, the partial rule keeps it. 640 (44 % closed) is rejected; so is a
    60 % share of an excess of 30, too small for the null's spread (saved 18 < penalty 2 + 2 sd 20)."""
    comparison = ModelComparison(_Band(), np.ones(CELLS))
    band, base, named = comparison.band, _fit(1080.0), ["lateral_kinematics"]
    kept = acceptance(comparison, named, base, band, _fit(480.0), band)
    assert kept["rule"] == "partial" and kept["share_closed"] == pytest.approx(0.6, abs=1e-9)
    assert kept["chi2_excess_before"] == pytest.approx(1000.0) and kept["chi2_saved"] == pytest.approx(600.0)
    assert kept["chi2_needed"] == pytest.approx(2.0 * 1 + 2.0 * 10.0)  # penalty of one parameter + 2 null sd
    assert acceptance(comparison, named, base, band, _fit(640.0), band)["rule"] == "rejected"  # 44 % closed < PARTIAL_SHARE
    small = acceptance(comparison, named, _fit(110.0, peak=4.0), band, _fit(92.0, peak=4.0), band)
    assert small["share_closed"] == pytest.approx(0.6) and small["rule"] == "rejected"
    assert acceptance(comparison, named, base, band, _fit(200.0), band)["rule"] == "halves"  # gap 1.22 <= half of 3.54
    assert acceptance(comparison, named, base, band, _fit(480.0, peak=2.0), band)["rule"] == "explains"  # inside the band's threshold
    assert "unrecognised" in kept["criterion"] and f"{PARTIAL_SHARE:g}" in kept["criterion"]


def test_the_course_angle_is_held_at_k_1_unless_released():
    """PHYSICAL names the course angle's k = 1 (its VANISHES value 0 is a different thing); an
    effect set holds it there, by its index among the set's parameters, unless released."""
    assert PHYSICAL == {"lateral_kinematics": ("k", 1.0)} and VANISHES["lateral_kinematics"] == ("k", 0.0)
    lo, hi = EFFECTS["lateral_kinematics"].bounds[0]
    assert lo < 1.0 < hi
    es = EffectSet(["road_bank", "lateral_kinematics"])
    assert es.physical() == {1: 1.0} and es.physical(release=("lateral_kinematics",)) == {}
    assert EffectSet(["road_bank"]).physical() == {}


def _late(ds, channel, lag):
    """``channel`` as a sensor sees it ``lag`` s late (its filter's or receiver's latency):
    x_measured(t) = x(t - lag), linear between samples, 0 before the first."""
    out = ds.copy(deep=True)
    t = out["time"].values
    out[channel].values[:] = np.array([np.interp(t - lag, t, row, left=0.0) for row in out[channel].values])
    return out


@pytest.fixture(scope="module")
def small(config):
    c = copy.deepcopy(config)
    c["time"].update(t_end=6.0)
    c["discrepancy"].update(model_samples=300, nonlinear_samples=100, bootstrap=40, max_times=60, top=2)
    return c


def _discover(small, ds):
    # no steering delay among the candidates: it shifts every channel and would stand in for a part
    # of one sensor's latency; the rest must be something no candidate models
    return DiscrepancyFinder(Settings.from_config(small), candidates=["lateral_kinematics", "road_bank", "sensor_bias"], seed=1).fit(ds).verdict_


@pytest.mark.long(5)
def test_course_angle_with_a_rest_nothing_explains_is_named_with_the_rest_unrecognised(small):
    """Exact course angle (5 deg slalom) plus a yaw-rate gyro 6 ms late, 150 runs: the course
    angle at k = 1 closes 57 % of the chi2 excess (3015 -> 1331, null sd 42), not half the RMS
    gap (2.48 -> 1.63): the halving rule alone says `unrecognised` with the gap unchanged. Kept
    as the partial truth, with the free k's interval holding 1 (1.00 [0.47, 1.53]: the gyro
    delay does not reach y) and the rest `unrecognised`. No candidate that closes half of the
    excess is left unnamed."""
    ds = _late(generate(small, HiddenEffectCase("k", "lateral_kinematics", 5.0, "slalom", {"period": 3.0}, samples=150, seed=5)), "psi_dot", 0.006)
    v = _discover(small, ds)
    assert [e["effect"] for e in v["effects"]] == ["lateral_kinematics", "unrecognised"]
    course = v["effects"][0]
    assert course["parameters"]["k"] == [1.0, 1.0, 1.0] and course["physical"] == {"k": 1.0}
    _, lo, hi = course["departure"]["fitted"]
    assert lo <= 1.0 <= hi and course["departure"]["holds_physical"] and not course["departure"]["departs"]
    acc = v["evidence"]["acceptance"]
    assert acc["rule"] == "partial" and acc["share_closed"] >= PARTIAL_SHARE and v["gap_after"] > 0.5 * v["gap_before"]
    assert v["gap_after"] < 0.8 * v["gap_before"]
    # never unrecognised alone where a candidate fitted closes half of the excess
    null = v["evidence"]["chi2_baseline"] - acc["chi2_excess_before"]
    closing = [c for c, s in v["evidence"]["candidates"].items() if s["chi2_linear_footing"] - null <= 0.5 * acc["chi2_excess_before"]]
    assert closing == ["lateral_kinematics"] and v["effect"] == "lateral_kinematics"


@pytest.mark.long(5)
def test_a_departure_of_k_is_reported_as_the_rest_acting_through_it(small):
    """Exact course angle plus a position receiver 10 ms late: y_measured ~ y - 0.01 v (psi + beta)
    cancels part of the course angle's v beta, and k fitted free goes to 0.66 [0.56, 0.77],
    where the model explains the data: a course angle of no car's kinematics, the delay hidden
    in it. Held at k = 1 the course angle closes 78 % of the excess, the rest is `unrecognised`,
    and the free k is reported as the rest acting through it."""
    ds = _late(generate(small, HiddenEffectCase("k", "lateral_kinematics", 5.0, "slalom", {"period": 3.0}, samples=150, seed=5)), "y", 0.01)
    v = _discover(small, ds)
    assert [e["effect"] for e in v["effects"]] == ["lateral_kinematics", "unrecognised"]
    course = v["effects"][0]
    assert course["parameters"]["k"] == [1.0, 1.0, 1.0]
    d = course["departure"]
    assert d["departs"] and not d["holds_physical"] and d["fitted"][2] < 0.9 and "acting through it" in d["reading"]
    assert d["chi2_saved"] > d["chi2_needed"] and d["chi2_fitted"] < d["chi2_at_physical"]

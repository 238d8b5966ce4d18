"""Discover bootstraps the non-linear footing's band only where a non-linear model is judged: the
baseline left the null (candidates are searched) or the start model is non-linear."""

from __future__ import annotations

import copy

import pytest

from uqdrive.inference.discrepancy import DiscrepancyFinder
from uqdrive.inference.discrepancy.comparison import NullBands
from uqdrive.settings import Settings
from uqdrive.studies.hidden_effects import HiddenEffectCase, generate

CANDIDATES = ["road_bank", "tyre_saturation"]


@pytest.fixture(scope="module")
def small(config):
    c = copy.deepcopy(config)
    c["time"].update(t_end=4.0)
    c["discrepancy"].update(model_samples=200, nonlinear_samples=60, bootstrap=30, max_times=60, top=1, max_effects=1)
    c["discrepancy"]["posterior"]["enabled"] = False
    return c


def _discover(config, case, monkeypatch):
    calls = []
    footing = NullBands.footing
    monkeypatch.setattr(NullBands, "footing", lambda self, base: calls.append(1) or footing(self, base))
    finder = DiscrepancyFinder(Settings.from_config(config), candidates=CANDIDATES).fit(generate(config, case))
    return finder, calls


def test_a_null_baseline_bootstraps_no_footing_band(small, monkeypatch):
    case = HiddenEffectCase("null", "none", 0.0, "step", {"amplitude_deg": 2.0}, samples=200, seed=7)
    finder, calls = _discover(small, case, monkeypatch)
    assert not finder.verdict_["evidence"]["significant"] and finder.verdict_["effect"] == "none"
    assert calls == [] and finder.footing_band_ is None and finder.verdict_["evidence"]["nonlinear_footing_band"] == {}


def test_a_gap_bootstraps_the_footing_band_for_the_nonlinear_candidate(small, monkeypatch):
    case = HiddenEffectCase("bank", "road_bank", 3.0, "step", {"amplitude_deg": 2.0}, samples=200, seed=7)
    finder, calls = _discover(small, case, monkeypatch)
    assert finder.verdict_["evidence"]["significant"]
    assert calls == [1] and finder.footing_band_ is not None
    assert finder.verdict_["evidence"]["nonlinear_footing_band"]["samples"] == 60

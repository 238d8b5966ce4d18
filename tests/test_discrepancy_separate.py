"""The input that would separate two ambiguous candidates (uqdrive.inference.discrepancy.separate):
a steering lag and a dead time of the same size look alike under a slow input and not under a
fast one; identical candidates are separated by nothing; straight driving separates nothing."""

import copy

import numpy as np
import pytest

from uqdrive.inference.discrepancy.fit import StructureFit
from uqdrive.inference.discrepancy.separate import separation, suggest_input
from uqdrive.studies.manoeuvres import steering_command
from uqdrive.vehicle.augmented import AugmentedSimulator
from uqdrive.vehicle.effects import EFFECTS
from uqdrive.settings import Settings

THETA = np.array([1.0, 0.2, 1.55, 0.2, -400.0, 400.0])


def test_separation_counts_standard_errors():
    a = np.ones((2, 4, 5))
    b = a.copy()
    n = 10**6
    assert separation(a, b, n, 10**12) == 0.0
    b[0, 2, 3] += 1.0 / np.sqrt(n)  # one standard error of a mean (std 1)
    b[1, 0, 0] += 2.0 / np.sqrt(2 * n)  # two of a std
    assert separation(a, b, n, 10**12) == pytest.approx(1.0 + 4.0, rel=1e-2)
    assert separation(a, b, n, n) == pytest.approx(5.0 / 2.0, rel=1e-2)  # a model of M = n doubles the variance


@pytest.fixture(scope="module")
def setting(config):
    c = copy.deepcopy(config)
    c["time"].update(t_end=6.0, dt=0.02)
    c["wind"]["kle_quadrature"] = 120
    t = np.arange(301) * 0.02
    inputs = {
        "straight": np.zeros_like(t),
        "slow_step": steering_command("step", t, {"amplitude_deg": 2.0, "ramp": 3.0}),
        "chirp": steering_command("chirp", t, {"amplitude_deg": 2.0, "f1": 2.0, "duration": 6.0}),
        "fast_slalom": steering_command("slalom", t, {"amplitude_deg": 2.0, "period": 1.0}),
    }
    sim = AugmentedSimulator.drawn(Settings.from_config(c), t, inputs["slow_step"], 70 / 3.6, 200, np.random.default_rng(2), stride=5, matched=True)
    return sim, inputs


def _fitted(sim, name, value):
    """A candidate as if fitted: its estimate set, no optimisation."""
    f = StructureFit(sim, np.arange(1, 61), np.full(4, 1e-8), effect=EFFECTS[name])
    f.theta_, f.effect_values_ = THETA, np.array([value])
    f.structure_ = f.structure(f.effect_values_)
    return f


def test_a_fast_input_separates_lag_from_delay(setting):
    sim, inputs = setting
    fits = {"actuator_lag": _fitted(sim, "actuator_lag", 0.15), "actuator_delay": _fitted(sim, "actuator_delay", 0.15),
            "actuator_lag_twin": _fitted(sim, "actuator_lag", 0.15)}
    [lag_delay, twins] = suggest_input(fits, [("actuator_lag", "actuator_delay"), ("actuator_lag", "actuator_lag_twin")], inputs, n=1000)
    by = lag_delay["by_input"]
    assert lag_delay["input"] in ("chirp", "fast_slalom") and lag_delay["separation"] == max(by.values())
    assert by["straight"] < 1e-6 and by["slow_step"] < 0.1 * lag_delay["separation"]
    assert lag_delay["separation"] > 100.0  # a chi-square no null band would miss
    assert max(twins["by_input"].values()) < 1e-6


def test_an_input_is_suggested_only_for_the_ambiguity_set(setting):
    """The verdict's ``separating_input``: one entry per candidate ambiguous with the named one,
    the measured input ranked too; nothing without ambiguity or without proposed inputs."""
    from uqdrive.inference.discrepancy.separate import separating_inputs

    sim, inputs = setting
    proposed = {k: v for k, v in inputs.items() if k != "slow_step"}
    fits = {"actuator_lag": _fitted(sim, "actuator_lag", 0.15), "actuator_delay": _fitted(sim, "actuator_delay", 0.15),
            "road_bank": _fitted(sim, "road_bank", 0.0)}
    [entry] = separating_inputs(fits, "actuator_lag", ["actuator_delay"], proposed, inputs["slow_step"], 1000)
    assert entry["candidates"] == ["actuator_lag", "actuator_delay"] and entry["input"] in ("chirp", "fast_slalom")
    assert set(entry["by_input"]) == {"measured", "straight", "chirp", "fast_slalom"} and entry["by_input"]["measured"] < entry["separation"]
    assert separating_inputs(fits, "actuator_lag", [], proposed, inputs["slow_step"], 1000) == []
    assert separating_inputs(fits, "actuator_lag", ["actuator_delay"], None, inputs["slow_step"], 1000) == []

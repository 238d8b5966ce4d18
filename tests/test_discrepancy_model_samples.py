"""The linear models' realisations sized to the data: min(model_samples, max(nonlinear_samples,
ceil(model_ratio n))) for the file's compared runs n, model_samples at ratio 0, and the verdict says which."""

import copy
import dataclasses

import numpy as np
import pytest

from uqdrive.inference.discrepancy import DiscrepancyFinder
from uqdrive.settings import Settings, Spin
from uqdrive.settings.run import model_realisations
from uqdrive.studies.hidden_effects import HiddenEffectCase, generate
from uqdrive.vehicle.augmented import AugmentedSimulator

CAP, FLOOR = 120, 50


@pytest.mark.parametrize("runs, ratio, expected", [
    (20, 0.0, CAP),     # ratio 0: the cap whatever the runs (the rule's value would be 50)
    (20, 2.0, FLOOR),   # 40 < floor
    (20, 3.05, 61),     # 61.0 up to float error: not 62
    (20, 3.06, 62),     # 61.2 rounded up
    (20, 10.0, CAP),    # 200 > cap
    (10, 0.7, FLOOR),
])
def test_the_rule_takes_the_ratio_between_its_floor_and_cap(runs, ratio, expected):
    assert model_realisations(runs, CAP, FLOOR, ratio) == expected


@pytest.fixture(scope="module")
def spun_file(config):
    """14 runs of a 2 s step, the 2 with the largest |beta| above the spin threshold: 12 compared."""
    c = copy.deepcopy(config)
    c["time"].update(t_end=2.0, dt=0.05, step=0.01)
    c["discrepancy"].update(model_samples=CAP, nonlinear_samples=FLOOR, bootstrap=20, max_times=20, top=1, posterior={"enabled": False})
    ds = generate(c, HiddenEffectCase("null", "none", 0.0, "step", {"amplitude_deg": 2.0}, samples=14, seed=7))
    peaks = np.sort(np.abs(ds["beta"].values).max(axis=1))
    settings = Settings.from_config(c)
    spin = Spin(threshold=float(0.5 * (peaks[-3] + peaks[-2])), policy="exclude")
    return ds, dataclasses.replace(settings, spin=spin)


class _Drawn(Exception):
    """Stops discover once the model's realisations are drawn."""


@pytest.mark.parametrize("ratio, expected", [
    (0.0, CAP),   # today's behaviour
    (3.0, FLOOR),  # 36: the floor
    (5.1, 62),    # 61.2 of the 12 compared runs (the 14 in the file would give 72)
    (11.0, CAP),  # 132: the cap
])
def test_discover_draws_the_rules_realisations_for_the_runs_it_compares(spun_file, monkeypatch, ratio, expected):
    ds, settings = spun_file
    drawn = []

    def record(cls, settings, t, delta, v_c, samples, rng, **kwargs):
        drawn.append(samples)
        raise _Drawn

    monkeypatch.setattr(AugmentedSimulator, "drawn", classmethod(record))
    s = dataclasses.replace(settings, discover=dataclasses.replace(settings.discover, model_ratio=ratio))
    with pytest.raises(_Drawn):
        DiscrepancyFinder(s, candidates=["road_bank"]).fit(ds)
    assert drawn == [expected]


def test_the_verdict_records_the_realisations_used_and_the_ratio(spun_file):
    """A whole (cheap) discover at ratio 5.1: the fits' simulator and the null band run on the 62
    realisations, and verdict.json's evidence says 62 and 5.1."""
    ds, settings = spun_file
    s = dataclasses.replace(settings, discover=dataclasses.replace(settings.discover, model_ratio=5.1))
    finder = DiscrepancyFinder(s, candidates=["road_bank"]).fit(ds)
    ev = finder.verdict_["evidence"]
    assert finder.samples_used_ == 12 and finder.model_samples == CAP
    assert finder.model_samples_ == 62 == finder.baseline_.simulator.germs.n
    assert ev["model_samples"] == 62 and ev["model_ratio"] == 5.1

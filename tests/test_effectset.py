"""EffectSet (several effects fitted as one) and resolvable (what the sampling can resolve):
pure bookkeeping and closed-form checks, no simulation."""

import numpy as np
import pytest

from uqdrive.inference.discrepancy.effectset import EffectSet, family_of, resolvable
from uqdrive.vehicle.effects import EFFECTS, ModelStructure

DT = 0.01  # s, the measured grid of the benchmark


def test_family_of_names_the_family_of_a_member_and_keeps_any_other_name():
    assert family_of("sensor_bias_y") == "sensor_bias"
    assert family_of("sensor_scale_beta") == "sensor_scale"
    assert family_of("actuator_lag") == "actuator_lag"  # in no family: the name itself


def test_an_effect_is_added_once_and_start_values_are_checked():
    with pytest.raises(ValueError, match="at most once"):
        EffectSet(["actuator_lag", "actuator_lag"])
    with pytest.raises(ValueError, match="do not match"):
        EffectSet(["actuator_lag"], {"actuator_lag": [0.1, 0.2]})
    s = EffectSet(["actuator_lag", "road_bank"], {"actuator_lag": [0.12]})
    assert s.start == (0.12, EFFECTS["road_bank"].start[0])  # a given start wins, the registry's fills in
    assert s.parameters == ("actuator_lag.T", "road_bank.phi")
    assert s.name == "actuator_lag+road_bank"


def test_split_gives_each_effect_its_own_slice_in_order():
    s = EffectSet(["lateral_load_transfer", "actuator_lag", "compliance_steer"])
    parts = s.split([0.6, -0.2, 0.1, 0.35])
    assert list(parts) == ["lateral_load_transfer", "actuator_lag", "compliance_steer"]
    np.testing.assert_array_equal(parts["lateral_load_transfer"], [0.6, -0.2])
    np.testing.assert_array_equal(parts["actuator_lag"], [0.1])
    np.testing.assert_array_equal(parts["compliance_steer"], [0.35])


def test_augment_applies_every_member_in_order_and_checks_the_length():
    s = EffectSet(["actuator_lag", "road_bank"])
    got = s.augment(ModelStructure(), [0.1, 2.0])
    want = EFFECTS["road_bank"].augment(EFFECTS["actuator_lag"].augment(ModelStructure(), [0.1]), [2.0])
    assert got == want
    assert got.steering_lag == 0.1 and got.lateral_acceleration != 0.0
    with pytest.raises(ValueError, match="take 2 parameter"):
        s.augment(ModelStructure(), [0.1])


def test_intervals_group_the_flat_names_per_effect():
    s = EffectSet(["lateral_load_transfer", "actuator_lag"])
    flat = {"lateral_load_transfer.chi_f": [0.6, 0.5, 0.7], "lateral_load_transfer.p_Dz": [-0.3, -0.4, -0.2], "actuator_lag.T": [0.1, 0.09, 0.11]}
    assert s.intervals(flat) == {"lateral_load_transfer": {"chi_f": [0.6, 0.5, 0.7], "p_Dz": [-0.3, -0.4, -0.2]},
                                 "actuator_lag": {"T": [0.1, 0.09, 0.11]}}


def test_a_delay_is_resolvable_from_one_sample_on():
    delta = np.zeros(100)
    assert not resolvable("actuator_delay", [0.4 * DT], delta, DT)[0]
    assert resolvable("actuator_delay", [DT], delta, DT)[0]  # exactly one sample: a shift of the samples
    assert resolvable("actuator_delay", [5 * DT], delta, DT) == (True, "")
    assert not resolvable("actuator_delay", [], delta, DT)[0]  # no size given: zero delay
    # the one-sample rule is the delay's only: a small value of another effect is not judged by it
    assert resolvable("tyre_saturation", [0.4 * DT], delta, DT) == (True, "")


def test_a_lag_is_resolvable_when_it_moves_the_input_more_than_the_reconstruction_does():
    # a step of 0.05 rad at t = 0.5 s: the linear and the held reconstructions differ by half the
    # jump at one of the 100 mid-sample times, RMS 0.025 / sqrt(100) = 2.5e-3 rad; a lag T moves the
    # input by about 0.05 sqrt(T / (2 dt) / 100) RMS: 0.5e-3 rad at T = 0.1 dt, 16e-3 at 0.2 s
    delta = np.where(np.arange(100) * DT >= 0.5, 0.05, 0.0)
    ok, why = resolvable("actuator_lag", [0.1 * DT], delta, DT)
    assert not ok and "reconstruction error" in why
    assert resolvable("actuator_lag", [0.2], delta, DT) == (True, "")
    # no lag on a straight-ahead input moves nothing and the floor is 0: not resolvable (0 <= 0)
    assert not resolvable("actuator_lag", [0.0], np.zeros(100), DT)[0]


def test_the_lag_is_counted_from_the_first_step_on():
    # a command that starts away from 0 jumps at t = 0 (wheel straight before): floor 0.5 a / sqrt(200)
    # = 1.06e-3 rad; a lag of 2 samples moves the input by about a exp(-k / 2) at sample k: 1.6e-3 rad
    # RMS from the first sample on, 1.0e-3 from the second: resolvable only when the first counts
    a = 0.03
    delta = np.full(200, a)
    assert resolvable("actuator_lag", [2 * DT], delta, DT)[0]

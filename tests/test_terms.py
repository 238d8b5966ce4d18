"""The terms of the augmented model (uqdrive.vehicle.effects.terms): every structure field in one
term, every candidate effect switching one on, and the step and pass grouping they decide."""

import dataclasses

import numpy as np
import pytest

from uqdrive.vehicle.effects import EFFECTS, ModelStructure
from uqdrive.vehicle.effects.terms import CHASSIS_FIELDS, TERMS, term_of


def test_every_field_of_the_structure_is_in_exactly_one_term():
    fields = [f.name for f in dataclasses.fields(ModelStructure) if f.name != "effects"]
    placed = [f for t in TERMS for f in t.fields]
    assert sorted(placed) == sorted(fields)  # none twice, none missing
    assert all(term_of(f).name == t.name for t in TERMS for f in t.fields)
    with pytest.raises(KeyError, match="no term"):
        term_of("effects")


def test_the_thesis_lst_has_no_term_on_and_every_effect_switches_one_on():
    assert ModelStructure().active_terms == () and not ModelStructure().nonlinear and not ModelStructure().uses_chassis
    for name, e in EFFECTS.items():
        values = [lo + 0.75 * (hi - lo) for lo, hi in e.bounds]  # inside the box, away from where an effect vanishes
        s = e.augment(ModelStructure(), values)
        assert s.active_terms, f"{name} at {values} switches no term on"


@pytest.mark.parametrize("name, terms, nonlinear, chassis", [
    ("tyre_saturation", ("tyre",), True, False),
    ("actuator_lag", ("actuator",), False, False),
    ("road_bank", ("disturbance",), False, False),
    ("compliance_steer", ("compliance_steer",), False, True),  # linear: a softer front axle
    ("tyre_relaxation", ("relaxation",), True, True),
])
def test_which_terms_an_effect_switches_on_decide_integration_and_the_chassis(name, terms, nonlinear, chassis):
    e = EFFECTS[name]
    s = e.augment(ModelStructure(), [hi for _, hi in e.bounds])
    assert (s.active_terms, s.nonlinear, s.uses_chassis) == (terms, nonlinear, chassis)


def test_the_step_is_the_shortest_an_active_term_needs():
    """At 20 m/s: a 0.1 m slip lag allows sigma / v = 5 ms, a 20 Hz roll mode 1 / (2 pi 20) = 7.96 ms,
    a 0.5 m lag (25 ms) and the 2 Hz roll mode (80 ms) leave the 10 ms limit."""
    limit = 0.01
    assert ModelStructure().max_step(20.0, limit) == limit
    assert ModelStructure(relaxation_length=0.5).max_step(20.0, limit) == limit
    assert ModelStructure(relaxation_length=0.1).max_step(20.0, limit) == pytest.approx(0.005, rel=1e-15)
    assert ModelStructure(roll_steer=1.0).max_step(20.0, limit) == limit
    assert ModelStructure(roll_steer=1.0, roll_frequency=20.0).max_step(20.0, limit) == pytest.approx(1 / (40 * np.pi), rel=1e-15)
    assert ModelStructure(roll_frequency=20.0).max_step(20.0, limit) == limit  # the roll mode without roll steer: off
    batch = ModelStructure(relaxation_length=np.array([0.0, 0.1, 0.05]))  # a batch: its largest lag, sigma / v = 5 ms
    assert batch.max_step(20.0, limit) == pytest.approx(0.005, rel=1e-15) and batch.uses_chassis


def test_structures_share_a_chassis_pass_only_with_the_same_switches():
    a, b = ModelStructure(pitch_height=0.5), ModelStructure(pitch_height=0.7)
    c = ModelStructure(load_sensitivity=-0.1)
    assert a.chassis_switches() == b.chassis_switches() != c.chassis_switches()
    assert len(ModelStructure().chassis_switches()) == sum(len(t.switches) for t in TERMS if t.chassis)
    assert set(CHASSIS_FIELDS) == {f for t in TERMS if t.chassis for f in t.fields}


def test_each_effect_says_where_it_vanishes_and_its_term_is_off_there():
    """The registry holds where each effect vanishes (``Effect.vanishes``): the parameter is the
    effect's own, and there the effect's term is off (the baseline's
    model), other parameters at their start values. Two keep a term on through another parameter,
    by their physics: the course angle's exact sine at k = 0 (y' = v sin psi), and the load-sensitive
    tyre's peak p_Dz beside its stiffness q. VANISHES and PHYSICAL are read from the registry."""
    import numpy as np

    from uqdrive.vehicle.effects import EFFECTS, PHYSICAL, VANISHES, ModelStructure

    through_another = {"lateral_kinematics": "kinematics", "load_sensitive_tyre": "load_sensitive_tyre"}
    assert VANISHES == {n: e.vanishes for n, e in EFFECTS.items() if e.vanishes is not None}
    assert PHYSICAL == {"lateral_kinematics": ("k", 1.0)}
    assert {"tyre_saturation", "tyre_shape"}.isdisjoint(VANISHES)  # the curvature E differs from the linear tyre at every E
    for name, (parameter, value) in VANISHES.items():
        e = EFFECTS[name]
        i = e.parameters.index(parameter)
        values = np.array(e.start, float)
        values[i] = value
        on = e.apply(ModelStructure(), values).active_terms
        assert on == ((through_another[name],) if name in through_another else ()), (name, on)
        values[i] = e.start[i] if e.start[i] != value else e.bounds[i][0] + 0.75 * (e.bounds[i][1] - e.bounds[i][0])
        assert e.apply(ModelStructure(), values).active_terms, f"{name}: no term on away from where it vanishes"

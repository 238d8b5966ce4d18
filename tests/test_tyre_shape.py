"""The tyre's own Magic-Formula shape as a candidate effect: b on the car's B_f and B_r, C and E
(uqdrive.vehicle.effects.TyreShape), simulated, batched and fitted."""

import numpy as np
import pytest

from uqdrive.inference.discrepancy.band import statistic_scale
from uqdrive.inference.discrepancy.fit import StructureFit
from uqdrive.settings import Settings
from uqdrive.vehicle.augmented import AugmentedSimulator
from uqdrive.vehicle.effects import shape_parts, with_tyre_shape
from uqdrive.vehicle.effects import EFFECTS, VANISHES, ModelStructure, effect
from uqdrive.vehicle.single_track import VehicleParameters
from uqdrive.vehicle.dynamics import SingleTrackRHS

V, N = 22.0, 12
B_FACTOR, C_SHAPE, E_CURV = 1.45, 1.3, -0.3  # a shape far from the car's (B_f 10.6, B_r 30.4, C 1.9, E 0.97)
THETA = np.array([1.0, 0.1, 1.55, 0.1, -400.0, 400.0])


def _shape(b=B_FACTOR, C=C_SHAPE, E=E_CURV):
    return effect("tyre_shape").augment(ModelStructure(), [b, C, E])


def test_the_registry_entry_and_the_structure_it_sets():
    """Three dimensionless parameters b, C, E, its start inside its bounds and away from the shape
    the tests fit; no vanishing value (every shape saturates); the Magic Formula with b, C, E set,
    and the car's B_f, B_r scaled by b, C replaced, the other constants untouched."""
    e = EFFECTS["tyre_shape"]
    assert e.parameters == ("b", "C", "E") and e.units == ("-", "-", "-") and "tyre_shape" not in VANISHES
    assert all(lo < st < hi for (lo, hi), st in zip(e.bounds, e.start))
    assert all(abs(st - truth) > 0.15 for st, truth in zip(e.start, (B_FACTOR, C_SHAPE, E_CURV)))
    s = _shape()
    assert s.tyre == "magic_formula" and s.nonlinear and s.tyre_curvature == E_CURV and s.tyre_shape() == (B_FACTOR, C_SHAPE)
    p = VehicleParameters()
    q = with_tyre_shape(p, s)
    assert (q.c_Sf, q.c_Sr, q.C) == (p.c_Sf * B_FACTOR, p.c_Sr * B_FACTOR, C_SHAPE) and (q.E, q.mu, q.m_base) == (p.E, p.mu, p.m_base)
    assert with_tyre_shape(p, ModelStructure()) is p and with_tyre_shape(p, effect("tyre_saturation").augment(ModelStructure(), [0.5])) is p


def _axle_forces(config, s):
    """Front and rear tyre forces (N), (2, N), of the single-track right-hand side with the
    structure's shape, recovered from its yaw and side-slip rates (no wind)."""
    rng = np.random.default_rng(4)
    mu = rng.uniform(0.6, 1.1, N)
    p = with_tyre_shape(VehicleParameters.from_settings(Settings.from_config(config), mu=mu, l_f=np.full(N, 1.55), v_c=V), s)
    delta = np.deg2rad([3.0, 4.0, 5.0])
    E = config["tyre"]["E"] if s.tyre_curvature is None else s.tyre_curvature
    rhs = SingleTrackRHS.of_structure(p, s, E, delta, np.zeros((3, N)), True, np.zeros(N))
    x = np.vstack([np.zeros(N), rng.uniform(0.1, 0.5, N), rng.uniform(-0.06, 0.02, N), np.zeros(N)])
    out = np.empty_like(x)
    rhs(x, 1, out)
    lateral = (out[2] + x[1]) * p.m * V / np.cos(x[2])  # F_f cos(delta) + F_r
    front = (p.I_z * out[1] + p.l_r * lateral) / p.wheelbase  # F_f cos(delta)
    return np.stack([front / np.cos(delta[1]), lateral - front]), x, p, mu, delta[1]


def test_each_axles_force_by_hand_from_the_magic_formula(config):
    """F_i = mu F_z,i sin(C atan(b B_i a_i - E (b B_i a_i - atan(b B_i a_i)))) at the slip angles
    of the states (rounding: 1e-9 of the largest force, the forces recovered through two divisions).
    With the term removed (the car's shape), b applied as 1 / b, or E's sign flipped, the golden
    value misses by more than 1 % of the largest force."""
    F, x, p, mu, delta = _axle_forces(config, _shape())
    base = VehicleParameters()
    alpha = np.stack([delta - np.arctan((V * np.sin(x[2]) + 1.55 * x[1]) / (V * np.cos(x[2]))),
                      -np.arctan((V * np.sin(x[2]) - p.l_r * x[1]) / (V * np.cos(x[2])))])
    loads = np.stack([p.F_fz, p.F_rz])

    def by_hand(b, E):
        Ba = b * np.array([[base.c_Sf], [base.c_Sr]]) * alpha
        return mu * loads * np.sin(C_SHAPE * np.arctan(Ba - E * (Ba - np.arctan(Ba))))

    scale = np.abs(F).max()
    np.testing.assert_allclose(F, by_hand(B_FACTOR, E_CURV), rtol=0, atol=1e-9 * scale)
    removed = _axle_forces(config, effect("tyre_saturation").augment(ModelStructure(), [config["tyre"]["E"]]))[0]
    for wrong in (removed, by_hand(1.0 / B_FACTOR, E_CURV), by_hand(B_FACTOR, -E_CURV)):
        assert np.abs(F - wrong).max() > 0.01 * scale


@pytest.fixture(scope="module")
def sim(config):
    t = np.arange(301) * 0.01
    delta = np.deg2rad(6.0) * np.sin(2 * np.pi * t / 2.0)
    return AugmentedSimulator.drawn(Settings.from_config(config), t, delta, 25.0, 24, np.random.default_rng(11), stride=4)


def test_pairs_of_different_shapes_batched_as_alone(sim):
    """A batch of two shapes and a plain saturating tyre: each pair's channels those it gets alone,
    bit for bit (a pass shares one B and C), and the shape moves the yaw rate by more than 5 % of its range."""
    structures = [_shape(), _shape(0.8, 1.6, 0.2), effect("tyre_saturation").augment(ModelStructure(), [0.5])]
    both = sim.simulate_many([THETA] * 3, structures)
    for got, s in zip(both, structures):
        np.testing.assert_array_equal(got, sim.simulate(THETA, s))
    assert np.abs(both[0][1] - both[2][1]).max() > 0.05 * np.ptp(both[2][1])
    grouped = sim.simulate_many([THETA] * 3, structures, groups=[2, 1])
    for got, s in zip(grouped, structures):
        np.testing.assert_array_equal(got, sim.simulate(THETA, s))


def test_b_C_E_fitted_jointly_with_the_distributions_from_the_start(sim):
    """The statistics of the model with b, C, E = 1.45, 1.3, -0.3 (a 6 deg slalom at 25 m/s, beta up
    to 3 deg) fitted from the registry's start (1.0, 1.6, 0.5) and mu's mean 10 % low: b, C, E
    within 1e-3 of their values (the same germs: the optimum is exact, its chi2 at rounding); the
    curvature alone (tyre_saturation) from its start leaves a chi2 above 1e3 on the same noise."""
    index = np.arange(1, sim.output_time.size)
    truth = _shape()
    noise = np.full(4, 1e-8)
    measured = StructureFit(sim, index, noise, 0.2).statistics(THETA, truth)
    scale = statistic_scale(sim.simulate(THETA, truth), index) + 1e-6
    start = THETA * [0.9, 1, 1, 1, 1, 1]
    e = EFFECTS["tyre_shape"]
    f = StructureFit(sim, index, noise, 0.2, effect=e, fit_theta=True, max_nfev=60).fit(measured, scale, start, effect_start=list(e.start))
    np.testing.assert_allclose(f.effect_values_, [B_FACTOR, C_SHAPE, E_CURV], atol=1e-3)
    sat = StructureFit(sim, index, noise, 0.2, effect=EFFECTS["tyre_saturation"], fit_theta=True, max_nfev=40).fit(
        measured, scale, start, effect_start=list(EFFECTS["tyre_saturation"].start))
    assert sat.chi2_ > 1e3


def test_a_batch_is_split_by_group_then_by_shape():
    """Indices by group and, within one, by shape in order of first use: a shape shared across two
    groups is two parts (each group's numbers its own call's)."""
    a, b, c = _shape(), _shape(0.8, 1.6, 0.2), ModelStructure()
    assert shape_parts([a, b, a, c]) == [[0, 2], [1], [3]]
    assert shape_parts([a, b, a, a], groups=[2, 2]) == [[0], [1], [2, 3]]


#: Chassis structures whose compiled rates read B and C in different loops: the loads' Newton
#: loop (lateral, longitudinal transfer and combined slip), the front's yield on those loads and
#: on static ones, the load-sensitive tyre's stepwise loop, the relaxing tyre with roll steer.
CHASSIS = {"lateral transfer": [("lateral_load_transfer", [0.5, -0.2])],
           "yield on the loads": [("lateral_load_transfer", [0.5, -0.2]), ("compliance_steer", [0.4])],
           "yield on static loads": [("compliance_steer", [0.4])],
           "pitch and combined slip": [("longitudinal_load_transfer", [0.5]), ("combined_slip", [1.0, 0.5])],
           "load-sensitive tyre": [("load_sensitive_tyre", [-0.3, -0.1])],
           "relaxation and roll steer": [("tyre_relaxation", [0.5]), ("roll_steer", [0.3, 2.0, 0.6])]}


@pytest.mark.parametrize("terms", list(CHASSIS), ids=list(CHASSIS))
def test_chassis_pairs_of_three_shapes_share_one_pass_with_the_numbers_of_each_alone(config, monkeypatch, terms):
    """A Jacobian's pairs on the tyre's shape with a chassis term (the point and its neighbours in
    b and in C and E) in one RK4 pass, each realisation with its pair's B and C: each pair's
    channels those it gets alone, bit for bit, compiled and by the NumPy reference alike; a pass
    that gave every pair the first pair's factors would differ (the shapes move the channels)."""
    from uqdrive.vehicle import augmented, track_extended

    t = np.arange(201) * 0.01
    delta = np.deg2rad(4.0) * np.sin(2 * np.pi * t / 1.5)
    settings = Settings.from_config({**config, "vehicle": {**config["vehicle"], "cg_height": 0.55, "track_width": 1.6}})
    sim = AugmentedSimulator.drawn(settings, t, delta, 22.0, 5, np.random.default_rng(3))
    structures = []
    for shape in ([1.0, 1.6, 0.5], [1.05, 1.6, 0.5], [1.0, 1.7, 0.3]):
        s = _shape(*shape)
        for name, values in CHASSIS[terms]:
            s = effect(name).augment(s, values)
        structures.append(s)
    thetas = [THETA * [1.0 - 0.02 * k, 1, 1, 1, 1, 1] for k in range(3)]
    passes = []
    one_pass = AugmentedSimulator._one_pass
    monkeypatch.setattr(AugmentedSimulator, "_one_pass", lambda self, th, *a, **k: passes.append(len(th)) or one_pass(self, th, *a, **k))
    shared = sim.simulate_many(thetas, structures)
    assert passes == [3]
    alone = [sim.simulate(th, s) for th, s in zip(thetas, structures)]
    for a, b in zip(shared, alone):
        np.testing.assert_array_equal(a, b)
    assert all(np.abs(alone[k] - alone[0]).max() > 1e-6 * np.abs(alone[0]).max() for k in (1, 2))
    monkeypatch.setattr(track_extended, "FUSED", False)
    for a, b in zip(sim.simulate_many(thetas, structures), alone):
        np.testing.assert_array_equal(a, b)
    assert augmented.shape_parts(structures) == [[0], [1], [2]]  # the single-track model's passes stay one shape each

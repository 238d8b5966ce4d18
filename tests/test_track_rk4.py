"""The in-place Magic-Formula RK4 (vehicle.track_rk4, numerics.integrate.rk4_fixed_step_into) and
the simulations built on it give the original right-hand side's numbers to the last bit: the emcee
posterior of a named tyre effect diverges on any change of the last bits (module docstring of
track_rk4), so the tests compare with ``np.array_equal``, not a tolerance."""

import numpy as np
import pytest

from uqdrive.numerics.integrate import rk4_fixed_step, rk4_fixed_step_into
from uqdrive.vehicle.augmented import AugmentedSimulator, actual_steering
from uqdrive.vehicle.axle_loads import half_angle_sin_cos
from uqdrive.vehicle.dynamics.engine import RK4_MAX_STEP
from uqdrive.vehicle.dynamics.fused_rk4 import rk4_fused_into
from uqdrive.vehicle.effects import EFFECTS, ModelStructure
from uqdrive.settings import Settings

THETA = np.array([1.0, 0.25, 1.5, 0.2, -400.0, 400.0])


def _reference_rhs(p, s, E):
    """The right-hand side written out (allocating, one expression per state), vectorised over
    realisations; sines and cosines of beta and the tyre's angle by the half-angle tangent."""
    v = float(p.v_c)
    l_f = np.asarray(p.l_f, float)
    l_r = p.l_r
    lever = np.stack(np.broadcast_arrays(l_f, -l_r))
    Bs = np.array([[p.c_Sf], [p.c_Sr]])
    peak = np.stack(np.broadcast_arrays(p.F_fz * p.mu, p.F_rz * p.mu))
    linear = np.stack(np.broadcast_arrays(p.c_f, p.c_r))
    inv_I_z, inv_mv = 1.0 / p.I_z, 1.0 / (p.m * v)
    C, k, a_lat = p.C, s.course_weight, s.lateral_acceleration

    def rhs(x, delta, F_w, M_w):
        psi, psi_dot, beta, _ = x
        sin_b, cos_b = half_angle_sin_cos(beta)
        slip = -np.arctan((v * sin_b + lever * psi_dot) / (v * cos_b))
        slip[0] += delta
        if s.tyre == "magic_formula":
            bx = Bs * slip
            F = peak * half_angle_sin_cos(C * np.arctan(bx - E * (bx - np.arctan(bx))))[0]
        else:
            F = linear * slip
        F_fy_cos = F[0] * np.cos(delta)
        out = np.empty_like(x)
        out[0] = psi_dot
        out[1] = (l_f * F_fy_cos - l_r * F[1] + M_w) * inv_I_z
        out[2] = (F_fy_cos + F[1] + F_w) * cos_b * inv_mv - psi_dot + a_lat / v
        out[3] = v * np.sin(psi + k * beta)
        return out

    return rhs


def _reference(sim, theta, s):
    """:meth:`AugmentedSimulator.simulate` of a structure by the reference right-hand side and
    the allocating RK4 (gusts as one product of the realisations' coefficients)."""
    p, wind, coeffs = sim.parameters(theta)
    coeffs = coeffs * s.gust_scale
    delta = actual_steering(sim.delta, sim.dt, s.steering_lag, s.steering_delay)
    sub = max(1, int(np.ceil(sim.dt / RK4_MAX_STEP - 1e-9)))
    h = sim.dt / sub
    n_steps = (sim.time.size - 1) * sub
    t_half = np.arange(2 * n_steps + 1) * (h / 2)
    delta_half = np.interp(t_half, sim.time, delta)
    gust_half = coeffs @ sim.kle.eigenfunctions(t_half)
    rhs = _reference_rhs(p, s, sim.car.E if s.tyre_curvature is None else s.tyre_curvature)

    def f(x, j):
        F_w = wind + gust_half[:, j]
        return rhs(x, delta_half[j], F_w, p.M_c * (F_w if sim.gust_yaw_moment else wind))

    out = rk4_fixed_step(f, np.zeros((4, wind.size)), h, n_steps, sub * sim.stride)
    x = out.transpose(1, 2, 0)
    return x * np.asarray(s.output_gain, float)[:, None, None] + np.asarray(s.output_offset, float)[:, None, None]


@pytest.fixture(scope="module")
def sim(config):
    t = np.arange(301) * 0.01
    delta = np.deg2rad(4.0) * np.sin(2 * np.pi * t / 2.0)
    return AugmentedSimulator.drawn(Settings.from_config(config), t, delta, 25.0, 24, np.random.default_rng(7), stride=4)


def _tyre(E, **kw):
    return EFFECTS["tyre_saturation"].augment(ModelStructure(**kw), [E])


STRUCTURES = {
    "thesis tyre": _tyre(0.97),
    "other curvature, course kinematics, bank": _tyre(0.3, course_weight=1.0, lateral_acceleration=0.4),
    "stronger gusts, actuator lag, sensor bias": _tyre(0.97, gust_scale=1.5, steering_lag=0.05, output_offset=(0.0, 0.0, 0.01, 0.0)),
}


@pytest.mark.parametrize("name", list(STRUCTURES))
def test_simulate_equals_the_reference_right_hand_side_bit_for_bit(sim, name):
    s = STRUCTURES[name]
    x = sim.simulate(THETA, s)
    assert x.shape == (4, 24, sim.output_time.size)
    assert np.array_equal(x, _reference(sim, THETA, s))


def test_without_the_gusts_yaw_moment_too(sim):
    other = sim.with_germs(sim.germs)
    other.gust_yaw_moment = not sim.gust_yaw_moment
    assert np.array_equal(other.simulate(THETA, STRUCTURES["thesis tyre"]), _reference(other, THETA, STRUCTURES["thesis tyre"]))


def test_a_linear_tyre_through_the_same_right_hand_side(sim):
    """The RK4 path with a linear tyre (simulate integrates a linear model exactly instead, but
    the right-hand side supports it) against the reference."""
    s = ModelStructure()
    p, wind, coeffs = sim.parameters(THETA)
    x = sim._rk4(p, wind, coeffs, actual_steering(sim.delta, sim.dt), s)
    assert np.array_equal(x, _reference(sim, THETA, s))


def test_batched_pairs_equal_their_own_groups_bit_for_bit(sim):
    """simulate_many's groups: each group's pairs get the numbers of a call of their own (one
    pair: simulate), whatever else shares the RK4 pass; without groups, one product for all
    (the numbers the reference gives the concatenated batch)."""
    thetas = [THETA, THETA * 1.01, THETA * 0.98]
    structures = [STRUCTURES["thesis tyre"], STRUCTURES["other curvature, course kinematics, bank"], STRUCTURES["thesis tyre"]]
    grouped = sim.simulate_many(thetas, structures, groups=[1, 2])
    assert np.array_equal(grouped[0], sim.simulate(thetas[0], structures[0]))
    for got, want in zip(grouped[1:], sim.simulate_many(thetas[1:], structures[1:])):
        assert np.array_equal(got, want)
    for got, th, s in zip(sim.simulate_many(thetas, structures), thetas, structures):
        assert np.allclose(got, sim.simulate(th, s), rtol=0, atol=1e-12 * np.abs(got).max())


@pytest.mark.parametrize("stepper", [rk4_fixed_step_into, rk4_fused_into], ids=["numpy", "compiled"])
def test_in_place_rk4_equals_the_allocating_one_bit_for_bit(stepper):
    """A stiff-ish non-linear test system (two states, several realisations), recorded every
    third step; the in-place stepper with NumPy's arithmetic and with its arithmetic compiled."""
    a = np.linspace(0.5, 3.0, 5)

    def f(x, j):
        return np.stack([x[1], -a * np.sin(x[0]) - 0.1 * x[1] + np.cos(0.01 * j)])

    def f_into(x, j, out):
        out[...] = f(x, j)

    x0 = np.stack([np.full(5, 0.3), np.zeros(5)])
    want = rk4_fixed_step(f, x0, 0.05, 60, 3)
    got = stepper(f_into, x0, 0.05, 60, 3)
    assert got.shape == (21, 2, 5) and np.array_equal(got, want)
    with pytest.raises(ValueError):
        stepper(f_into, x0, 0.05, 61, 3)


def _chassis(sigma=0.4, roll=(0.35, 2.4, 0.6), transfer=(0.55, -0.3), gain=1.0):
    s = EFFECTS["lateral_load_transfer"].augment(_tyre(0.97), list(transfer)) if transfer else _tyre(0.97)
    s = EFFECTS["tyre_relaxation"].augment(s, [sigma])
    s = EFFECTS["roll_steer"].augment(s, list(roll)) if roll else s
    return EFFECTS["sensor_scale_beta"].augment(s, [gain]) if gain != 1.0 else s


@pytest.mark.parametrize("channels", [None, ("psi_dot", "beta", "a_y")])
def test_chassis_pairs_batched_equal_their_own_simulation_bit_for_bit(config, channels):
    """simulate_many of chassis structures (a Jacobian's neighbours, and pairs with another RK4
    step or another set of terms) integrates the pairs of one kind in one pass, each pair with
    the numbers of simulate: another step (sigma 0.1 m at 25 m/s needs 4 ms, 0.4 m 16 ms) or
    another term (no load transfer: the loads' Newton loop rounds) in the same pass would change them."""
    cfg = {**config, "vehicle": {**config["vehicle"], "cg_height": 0.55, "track_width": 1.6}}
    t = np.arange(201) * 0.01
    kw = {} if channels is None else {"channels": channels}
    sim = AugmentedSimulator.drawn(Settings.from_config(cfg), t, np.deg2rad(3.0) * np.sin(2 * np.pi * t / 1.5), 25.0, 12, np.random.default_rng(3), stride=4, **kw)
    thetas = [THETA, THETA + [1e-4, 0, 0, 0, 0, 0]] + [THETA] * 6
    structures = [_chassis(), _chassis(), _chassis(transfer=(0.5501, -0.3)), _chassis(sigma=0.1), _chassis(roll=None),
                  _chassis(transfer=None), _chassis(gain=1.02), _tyre(0.97)]
    batched = sim.simulate_many(thetas, structures)
    for got, th, s in zip(batched, thetas, structures):
        assert np.array_equal(got, sim.simulate(th, s))
    assert not np.array_equal(batched[0], batched[3]) and not np.array_equal(batched[0], batched[4])


def test_linear_pairs_along_a_speed_profile_batched_equal_their_own_simulation_bit_for_bit(config, monkeypatch):
    """simulate_many of linear structures along a speed profile (a Jacobian's neighbours, and
    pairs with a bank, course kinematics, compliance, stronger gusts, an output map, another
    steering lag) integrates the pairs that can share a pass in passes of at most
    _PASS_REALISATIONS realisations, each pair with the numbers of simulate: a pair given
    another's parameters, gusts, steering or kinematics in the pass would differ from them."""
    import uqdrive.vehicle.augmented as augmented

    t = np.arange(201) * 0.01
    speed = np.interp(t, [0.0, 0.5, 1.5, 2.0], [25.0, 25.0, 18.0, 18.0])
    sim = AugmentedSimulator.drawn(Settings.from_config(config), t, np.deg2rad(3.0) * np.sin(2 * np.pi * t / 1.5), 21.5, 12,
                                   np.random.default_rng(3), stride=4, channels=("psi", "psi_dot", "beta", "y", "a_y"), speed=speed)
    monkeypatch.setattr(augmented, "_PASS_REALISATIONS", 36)  # three pairs a pass
    base = ModelStructure()
    neighbours = [THETA] + [THETA + 1e-3 * np.abs(THETA).max() * np.eye(6)[i] for i in range(6)]
    others = [EFFECTS["road_bank"].augment(base, [2.0]), EFFECTS["road_bank"].augment(base, [2.1]),
              EFFECTS["lateral_kinematics"].augment(base, [0.7]), EFFECTS["compliance_steer"].augment(base, [0.4]),
              EFFECTS["wind_gust"].augment(base, [2.0]), EFFECTS["sensor_scale_a_y"].augment(base, [1.1]),
              EFFECTS["actuator_lag"].augment(base, [0.08])]
    thetas, structures = neighbours + [THETA] * len(others), [base] * len(neighbours) + others
    passes = []
    one_pass = AugmentedSimulator._one_pass
    monkeypatch.setattr(AugmentedSimulator, "_one_pass", lambda self, th, st, *a, **k: passes.append(len(th)) or one_pass(self, th, st, *a, **k))
    batched = sim.simulate_many(thetas, structures)
    for got, th, s in zip(batched, thetas, structures):
        assert np.array_equal(got, sim.simulate(th, s))
    # the ten of the plain kinematics and input in passes of three and a single, the two banks in one;
    # the exact kinematics' and the lag's pairs alone
    assert sorted(passes) == [2, 3, 3, 3] and sum(passes) == len(thetas) - 3
    assert all(not np.array_equal(batched[0], x) for x in batched[1:])


@pytest.mark.parametrize("interpolation, speed", [("linear", False), ("previous", False), ("linear", True)])
def test_tyre_pairs_with_other_steering_batched_equal_their_own_simulation_bit_for_bit(config, monkeypatch, interpolation, speed):
    """simulate_many of Magic-Formula structures whose steering lag or delay differ (a fitted
    lag's and delay's difference neighbours) integrates them in passes of at most
    _PASS_REALISATIONS realisations, each pair steered by its own actual angle, with the numbers
    of simulate: a pair given another's steering in the pass would differ from them."""
    import uqdrive.vehicle.augmented as augmented

    t = np.arange(201) * 0.01
    kw = {"channels": ("psi_dot", "a_y"), "speed": np.interp(t, [0.0, 0.5, 1.5, 2.0], [25.0, 25.0, 18.0, 18.0])} if speed else {}
    sim = AugmentedSimulator.drawn(Settings.from_config(config), t, np.deg2rad(3.0) * np.sin(2 * np.pi * t / 1.5), 21.5, 12,
                                   np.random.default_rng(3), stride=4, interpolation=interpolation, **kw)
    monkeypatch.setattr(augmented, "_PASS_REALISATIONS", 36)  # three pairs a pass
    structures = [_tyre(0.97, steering_lag=0.05, steering_delay=0.02), _tyre(0.97, steering_lag=0.05 + 1e-5, steering_delay=0.02),
                  _tyre(0.97, steering_lag=0.05, steering_delay=0.02 + 1e-5), _tyre(0.9, steering_lag=0.05, steering_delay=0.02),
                  _tyre(0.97, steering_lag=0.05, course_weight=1.0, course_exact=True)]
    thetas = [THETA, THETA, THETA, THETA * 1.01, THETA]
    passes = []
    one_pass = AugmentedSimulator._one_pass
    monkeypatch.setattr(AugmentedSimulator, "_one_pass", lambda self, th, st, *a, **k: passes.append(len(th)) or one_pass(self, th, st, *a, **k))
    batched = sim.simulate_many(thetas, structures)
    assert passes == [3]  # four of one kinematics: a pass of three, then one alone (simulate); the exact course alone
    for got, th, s in zip(batched, thetas, structures):
        assert np.array_equal(got, sim.simulate(th, s))
    assert all(not np.array_equal(batched[0], x) for x in batched[1:])


def test_kept_gust_products_give_the_numbers_of_a_fresh_simulator(sim):
    """The gust products a simulator keeps (shared with its copies on other germs) are looked up
    by the germs and the gust scale: simulations after others on other gusts equal those of a
    simulator that computes every product anew, and a stronger gust changes them."""
    gusty = EFFECTS["wind_gust"].augment(STRUCTURES["thesis tyre"], [2.0])
    other = sim.with_germs(type(sim.germs).draw(np.random.default_rng(9), sim.germs.n, sim.germs.kle.shape[1]))  # as many
    runs = [(sim, STRUCTURES["thesis tyre"]), (sim, gusty), (other, STRUCTURES["thesis tyre"]), (sim, STRUCTURES["thesis tyre"])]
    got = [s.simulate(THETA, st) for s, st in runs]
    for x, (s, st) in zip(got, runs):
        fresh = s.with_germs(s.germs)
        fresh._gust_products = {}
        assert np.array_equal(x, fresh.simulate(THETA, st))
    assert not np.array_equal(got[0], got[1]) and np.array_equal(got[0], got[3])


@pytest.mark.parametrize("profile", [True, False])
def test_sensors_without_heading_get_the_full_models_numbers(config, profile):
    """A model recorded without psi and y integrates psi_dot and beta alone (neither psi nor y
    enters them): its channels equal those of the four-state integration bit for bit, the
    linear model along a speed profile and the Magic-Formula one at a held speed or along it,
    with the gusts' yaw moment on and off and with a bank."""
    t = np.arange(201) * 0.01
    speed = np.interp(t, [0.0, 0.5, 1.5, 2.0], [25.0, 25.0, 18.0, 18.0]) if profile else None
    full = AugmentedSimulator.drawn(Settings.from_config(config), t, np.deg2rad(3.0) * np.sin(2 * np.pi * t / 1.5), 21.5, 12,
                                    np.random.default_rng(3), stride=4, channels=("psi", "psi_dot", "beta", "y", "a_y"), speed=speed)
    imu = full.with_germs(full.germs)
    imu.channels = ("a_y", "psi_dot", "beta")
    bank = EFFECTS["road_bank"].augment(ModelStructure(), [2.0])
    for yaw in (True, False):
        full.gust_yaw_moment = imu.gust_yaw_moment = yaw
        for s in ([ModelStructure(), bank] if profile else []) + [_tyre(0.6), EFFECTS["road_bank"].augment(_tyre(0.6), [2.0])]:
            want, got = full.simulate(THETA, s), imu.simulate(THETA, s)
            assert np.array_equal(got, want[[4, 1, 2]]) and np.all(np.isfinite(got))


def test_a_pass_after_a_larger_or_smaller_one_gives_a_fresh_simulators_numbers(config):
    """The wind table of an RK4 pass reuses the previous pass's memory (uninitialised, of another
    size): every pass writes all of it first, so a pass gives the numbers of a fresh simulator
    whatever ran before it, a_y from its right-hand side included. And the memory is reused."""
    t = np.arange(201) * 0.01
    make = lambda: AugmentedSimulator.drawn(Settings.from_config(config), t, np.deg2rad(3.0) * np.sin(2 * np.pi * t / 1.5), 25.0, 12,  # noqa: E731
                                            np.random.default_rng(3), stride=4, channels=("psi_dot", "beta", "a_y"))
    tyre = EFFECTS["tyre_saturation"].augment(ModelStructure(), [-1.0])
    lag = EFFECTS["actuator_lag"].augment(tyre, [0.08])
    fresh_one, fresh_many = make().simulate(THETA, lag), make().simulate_many([THETA, 1.1 * THETA, THETA], [tyre, tyre, lag])
    sim = make()
    many = sim.simulate_many([THETA, 1.1 * THETA, THETA], [tyre, tyre, lag])  # a larger pass first
    one = sim.simulate(THETA, lag)
    again = sim.simulate_many([THETA, 1.1 * THETA, THETA], [tyre, tyre, lag])  # then a larger one again
    assert np.array_equal(one, fresh_one)
    for a, b, c in zip(many, again, fresh_many):
        assert np.array_equal(a, c) and np.array_equal(b, c)
    small, large = sim._wind_half(10, 12), sim._wind_half(20, 36)
    assert np.shares_memory(small, large) and small.flags.c_contiguous and large.shape == (20, 36)


@pytest.mark.parametrize("modes", [5, 10])
def test_the_gust_table_is_the_product_in_its_time_major_layout(sim, modes):
    """A pass's gust table (J, n) is f_half' c' as BLAS writes it: with the configured wind's
    five modes a part of the realisations gets the columns of the whole table, bit for bit (the
    side-by-side sets of a footing's band need it); the transposed product c f_half within 1e-15
    of the largest gust (whether its bits agree depends on the CPU's BLAS kernel)."""
    rng = np.random.default_rng(modes)
    f_half, coeffs = rng.standard_normal((modes, 801)), 300.0 * rng.standard_normal((400, modes))
    t_half = np.arange(801) * 0.005
    fresh = sim.with_germs(sim.germs)
    fresh._gust_products = {}
    table = fresh._gusts(coeffs, f_half, t_half)
    assert table.shape == (801, 400) and table.flags.c_contiguous
    product = np.ascontiguousarray((coeffs @ f_half).T)
    if modes <= 7:  # a part of the realisations gets the columns of the whole table, bit for bit
        assert np.array_equal(fresh._gusts(coeffs[40:80], f_half, t_half), table[:, 40:80])
    np.testing.assert_allclose(table, product, rtol=0, atol=1e-15 * np.abs(product).max())

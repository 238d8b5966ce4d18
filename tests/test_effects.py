"""The augmented single-track model: every registered effect enters where its physics says, and
the simulator agrees with uqdrive's own LST and NLST ensembles on the same draws."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from uqdrive.vehicle.augmented import AugmentedSimulator, Germs, actual_steering
from uqdrive.vehicle.uncertainty import germ_from_uniform
from uqdrive.vehicle.effects import EFFECTS, FAMILIES, ModelStructure, effect, expand_names, structure_from_effects
from uqdrive.vehicle.montecarlo import simulate_ensemble
from uqdrive.settings import Settings

THETA = [1.0, 0.2, 1.55, 0.2, -400.0, 400.0]


def _germs_of(ds, config):
    u = config["uncertainty"]
    return Germs(mu=(ds.mu.values - u["mu"]["mean"]) / u["mu"]["std"], l_f=(ds.l_f.values - u["l_f"]["mean"]) / u["l_f"]["std"],
                 m_load=(ds.m_load.values - u["m_load"]["mean"]) / u["m_load"]["std"],
                 wind=germ_from_uniform(ds.F_w_mean.values, u["F_w_mean"]["low"], u["F_w_mean"]["high"]), kle=ds.xi_wind.values)


@pytest.fixture(scope="module")
def ensembles(config):
    return {m: simulate_ensemble(Settings.from_config(config), m, samples=40) for m in ("lst", "nlst")}


def _states(ds):
    return np.stack([ds[v].values for v in ("psi", "psi_dot", "beta", "y")])


@pytest.mark.parametrize("model", ["lst", "nlst"])
def test_baseline_and_tyre_saturation_equal_uqdrives_ensembles_on_the_same_draws(config, ensembles, model):
    """Same draws, same physics: the LST by exact FOH on the output grid agrees with the 5 ms
    FOH ensemble to the steering's linear-interpolation error (< 1e-4 of each state's range);
    the Magic-Formula model by RK4 at 10 ms with the 5 ms NLST to RK4's error (< 2e-3)."""
    ds = ensembles[model]
    sim = AugmentedSimulator(Settings.from_config(config), ds.time.values, ds.delta.values, ds.attrs["v_c"], _germs_of(ds, config))
    s = ModelStructure() if model == "lst" else effect("tyre_saturation").augment(ModelStructure(), [config["tyre"]["E"]])
    x, X = sim.simulate(THETA, s), _states(ds)
    err = np.abs(x - X).max(axis=(1, 2)) / np.abs(X).max(axis=(1, 2))
    assert np.all(err < (1e-4 if model == "lst" else 2e-3)), err
    if model == "nlst":  # and the linear model is not the NLST: the check can fail
        lin = sim.simulate(THETA)
        assert np.abs(lin - X).max(axis=(1, 2))[1] / np.abs(X[1]).max() > 0.05


def test_actual_steering_lag_is_exact_and_delay_is_a_shift():
    """The FOH lag formula against a tight ODE solution (1e-7 rad), zero before t = 0."""
    dt = 0.01
    t = np.arange(401) * dt
    d = 0.1 * np.sin(2 * np.pi * 0.5 * t) + 0.02 * (t > 1.0) * (t - 1.0)
    for T in (0.05, 0.3):
        ref = solve_ivp(lambda s, x: (np.interp(s, t, d) - x) / T, (0, t[-1]), [0.0], t_eval=t, rtol=1e-11, atol=1e-13, max_step=dt / 4).y[0]
        assert np.abs(actual_steering(d, dt, lag=T) - ref).max() < 1e-7
    shifted = actual_steering(d, dt, delay=0.15)
    assert np.allclose(shifted[15:], d[:-15], atol=1e-12) and np.all(shifted[:15] == 0.0)


def test_output_effects_touch_only_their_channel(config):
    t = np.arange(301) * 0.01
    sim = AugmentedSimulator.drawn(Settings.from_config(config), t, 0.05 * np.sin(t), 19.4, 20, np.random.default_rng(3))
    base = sim.simulate(THETA)
    biased = sim.simulate(THETA, effect("sensor_bias_psi_dot").augment(ModelStructure(), [0.01]))
    scaled = sim.simulate(THETA, effect("sensor_scale_beta").augment(ModelStructure(), [1.2]))
    assert np.allclose(biased[1] - base[1], 0.01) and np.array_equal(np.delete(biased, 1, 0), np.delete(base, 1, 0))
    assert np.allclose(scaled[2], 1.2 * base[2]) and np.array_equal(np.delete(scaled, 2, 0), np.delete(base, 2, 0))


def test_road_bank_and_course_kinematics_enter_as_physics_says(config):
    """A bank adds g sin(phi) / v to beta_dot (a lateral drift of y growing with time); the
    course-angle kinematics changes y only, to v * integral(sin(psi + k beta))."""
    t = np.arange(501) * 0.01
    sim = AugmentedSimulator.drawn(Settings.from_config(config), t, np.zeros_like(t), 19.4, 10, np.random.default_rng(4))
    theta = [1.0, 0.0, 1.55, 0.0, 0.0, 0.0]
    cfg_sigma = sim.sigma
    sim.sigma = 0.0
    banked = sim.simulate(theta, effect("road_bank").augment(ModelStructure(), [2.0]))
    assert banked[3, :, -1].mean() > 0.1 and banked[2, :, -1].mean() > 0  # drifts to +y
    d = 0.05 * np.sin(2 * t)
    sim2 = AugmentedSimulator.drawn(Settings.from_config(config), t, d, 19.4, 10, np.random.default_rng(4))
    base = sim2.simulate(theta)
    course = sim2.simulate(theta, effect("lateral_kinematics").augment(ModelStructure(), [1.0]))
    assert np.allclose(course[:3], base[:3])
    gap = np.sin(base[0] + base[2]) - base[0]  # the heading model's y_dot is v psi
    expected = base[3] + 19.4 * np.concatenate([np.zeros((10, 1)), np.cumsum((gap[:, 1:] + gap[:, :-1]) / 2 * 0.01, axis=1)], axis=1)
    assert np.abs(course[3] - expected).max() < 1e-3 * np.abs(course[3]).max()
    sim.sigma = cfg_sigma


def test_gust_scale_multiplies_the_gust_response(config):
    t = np.arange(301) * 0.01
    sim = AugmentedSimulator.drawn(Settings.from_config(config), t, np.zeros_like(t), 19.4, 15, np.random.default_rng(5))
    theta = [1.0, 0.1, 1.55, 0.1, 0.0, 0.0]  # no mean wind: the response is the gusts' alone
    one, three = sim.simulate(theta), sim.simulate(theta, effect("wind_gust").augment(ModelStructure(), [3.0]))
    assert np.allclose(three, 3.0 * one, atol=1e-12)


def test_registry_names_families_and_model_documents():
    assert set(FAMILIES["sensor_bias"]) <= set(EFFECTS) and expand_names(["sensor_bias"]) == list(FAMILIES["sensor_bias"])
    with pytest.raises(KeyError, match="unknown effect 'tyre_wear'"):
        effect("tyre_wear")
    s = structure_from_effects({"actuator_lag": {"T": 0.1}, "road_bank": {"phi": 1.0}})
    assert s.steering_lag == 0.1 and s.lateral_acceleration == pytest.approx(9.81 * np.sin(np.deg2rad(1.0)))
    assert [e[0] for e in s.effects] == ["actuator_lag", "road_bank"]
    with pytest.raises(ValueError, match="needs parameter"):
        structure_from_effects({"actuator_lag": {}})
    for name, e in EFFECTS.items():  # every effect changes the model, with parameters in bounds
        assert 1 <= len(e.parameters) <= 3 and len(e.bounds) == len(e.start) == len(e.parameters)
        assert all(lo <= s0 <= hi for (lo, hi), s0 in zip(e.bounds, e.start))
        moved = e.augment(ModelStructure(), [b[1] * 0.5 + b[0] * 0.5 + 0.1 for b in e.bounds])
        assert moved != ModelStructure()


@pytest.mark.parametrize("structure", [ModelStructure(), effect("tyre_saturation").augment(ModelStructure(), [0.9])])
def test_strided_output_equals_the_full_grid_subsampled(config, structure):
    """The folded first-order-hold maps (and RK4 recording) are exact: a stride changes nothing
    but which states are returned (to round-off)."""
    t = np.arange(301) * 0.01
    d = 0.06 * np.sin(2.5 * t)
    germs = Germs.draw(np.random.default_rng(6), 12, 5)
    full = AugmentedSimulator(Settings.from_config(config), t, d, 19.4, germs).simulate(THETA, structure)
    strided = AugmentedSimulator(Settings.from_config(config), t, d, 19.4, germs, stride=7)
    assert np.allclose(strided.simulate(THETA, structure), full[:, :, : strided.time.size : 7], rtol=1e-9, atol=1e-12)
    assert strided.output_time[-1] == pytest.approx(294 * 0.01)


def test_moment_matched_germs_have_the_populations_mean_and_covariance():
    """Germs.matched: sample mean 0 and covariance I of (mu, l_f, m_load, sqrt(3) xi, KLE
    modes) exactly, a near-identity change (the uniform germ stays nearly uniform); too few
    realisations to whiten are refused. Unmatched, the same draws miss both by O(M^-1/2)."""
    g = Germs.draw(np.random.default_rng(0), 400, 5)
    m = g.matched()
    z = lambda h: np.column_stack([h.mu, h.l_f, h.m_load, np.sqrt(3.0) * h.wind, h.kle])  # noqa: E731
    assert np.allclose(z(m).mean(axis=0), 0.0, atol=1e-12) and np.allclose(np.cov(z(m), rowvar=False), np.eye(9), atol=1e-10)
    assert np.abs(np.cov(z(g), rowvar=False) - np.eye(9)).max() > 0.05
    assert np.abs(z(m) - z(g)).max() < 0.5 and -1.1 < m.wind.min() and m.wind.max() < 1.1
    assert np.allclose(Germs.draw(np.random.default_rng(0), 400, 5, matched=True).kle, m.kle)
    with pytest.raises(ValueError, match="more than 9"):
        g.head(9).matched()


def test_with_input_steers_the_same_germs_by_another_command(config):
    t = np.arange(201) * 0.01
    sim = AugmentedSimulator.drawn(Settings.from_config(config), t, np.zeros_like(t), 70 / 3.6, 20, np.random.default_rng(1))
    steered = sim.with_input(np.deg2rad(2.0) * np.ones_like(t))
    assert steered.germs is sim.germs and np.allclose(steered.delta, np.deg2rad(2.0))
    assert np.abs(steered.simulate(THETA)[1] - sim.simulate(THETA)[1]).max() > 1e-3  # yaw rate answers the step
    with pytest.raises(ValueError, match="samples"):
        sim.with_input(np.zeros(5))

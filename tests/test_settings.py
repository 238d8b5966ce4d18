"""The typed settings are the config's numbers, parsed once: the car's constants in either form,
the speed converted once, the data's facts replacing the config's, and the provenance unchanged."""

import copy

import numpy as np
import pytest

from uqdrive.config import ConfigError, config_hash, restrict_config, validate_config
from uqdrive.settings import ENSEMBLE_SETTINGS, Normal, ParameterLayout, Settings, TimeGrid, Uniform, ensemble_hash


def test_the_car_and_its_speed_are_the_configs(config):
    s = Settings.from_config(config)
    veh = config["vehicle"]
    assert (s.vehicle.m_base, s.vehicle.J0, s.vehicle.wheelbase, s.vehicle.c_Sf) == (veh["m_base"], veh["J0"], veh["wheelbase"], veh["c_Sf"])
    assert s.vehicle.v_c == veh["speed_kmh"] / 3.6 and s.vehicle.E == config["tyre"]["E"]
    # a data speed goes through km/h as a config's does, so both give the same float
    assert s.vehicle.at_speed(25.0).v_c == (25.0 * 3.6) / 3.6 and s.vehicle.at_speed(25.0).speed_kmh == 90.0


def test_engineering_units_give_the_internal_constants(config):
    """mass 1784 kg and yaw inertia 1498.56 kg m^2 are m_base 1784 and J0 = I_z / m = 0.84 m^2, equal
    to rounding (one product and one division); the yaw inertia of another mass is another J0."""
    raw = copy.deepcopy(config)
    veh = {k: v for k, v in raw["vehicle"].items() if k not in ("m_base", "J0")}
    raw["vehicle"] = {**veh, "mass": 1784.0, "yaw_inertia": 0.84 * 1784.0}
    s = Settings.from_config(validate_config(raw))
    assert s.vehicle.m_base == 1784.0 and s.vehicle.J0 == pytest.approx(0.84, rel=1e-15)
    raw["vehicle"]["yaw_inertia"] = 0.84 * 2000.0
    assert Settings.from_config(validate_config(raw)).vehicle.J0 == pytest.approx(0.84 * 2000.0 / 1784.0, rel=1e-15)


def test_known_quantities_leave_the_layout_and_theta(config):
    c = copy.deepcopy(config)
    c["uncertainty"]["l_f"]["std"] = 0.0
    c["uncertainty"]["F_w_mean"] = {"low": 50.0, "high": 50.0}
    s = Settings.from_config(c)
    assert s.uncertainty.known() == {"l_f": c["uncertainty"]["l_f"]["mean"], "F_w_mean": 50.0}
    assert dict(s.layout.known) == {2: c["uncertainty"]["l_f"]["mean"], 3: 0.0, 4: 50.0, 5: 50.0}
    assert s.uncertainty.theta(("mu", "l_f", "F_w_mean")).tolist() == [c["uncertainty"]["mu"]["mean"], c["uncertainty"]["mu"]["std"]]
    assert dict(Settings.from_config(config).layout.known) == {}


def test_the_data_grid_and_speed_replace_the_configs_and_its_hash(config):
    s = Settings.from_config(config)
    assert s.ensemble_hash(48, 1) == ensemble_hash(config, 48, 1) == config_hash(
        {"settings": restrict_config(config, ENSEMBLE_SETTINGS), "samples": 48, "seed": 1})
    grid = TimeGrid(3.0, 0.02, 0.02)
    d = Settings.from_config(config, time=grid, speed=25.0)
    assert d.time == grid and d.vehicle.v_c == (25.0 * 3.6) / 3.6
    edited = {**config, "time": {"t_end": 3.0, "dt": 0.02, "step": 0.02}, "vehicle": {**config["vehicle"], "speed_kmh": 25.0 * 3.6}}
    assert d.ensemble_hash(48, 1) == ensemble_hash(edited, 48, 1) != s.ensemble_hash(48, 1)
    assert np.allclose(d.time.output[[0, -1]], [0.0, 3.0]) and d.time.substeps == 1


def test_an_absent_optional_quantity_is_named_with_its_use(config):
    veh = Settings.from_config(config).vehicle
    with pytest.raises(ConfigError, match="the effect x needs config key 'vehicle.cg_height'"):
        veh.require("cg_height", "the effect x")


def test_discover_settings_take_the_sections_values_or_the_defaults(config):
    d = Settings.from_config(config).discover
    assert d.model_samples == config["discrepancy"]["model_samples"] and "enabled" not in d.posterior
    assert d.wants_posterior("tyre_saturation") and not d.wants_posterior("sensor_bias")
    bare = Settings.from_config({k: v for k, v in config.items() if k != "discrepancy"}).discover
    assert bare.candidates is None and bare.model_samples == 1000 and not bare.wants_posterior("tyre_saturation")


def test_the_two_search_boxes_are_those_of_identify_and_discover():
    assert ParameterLayout.identify_box(("l_f_mean", "mu_std"), 2.85) == [(0.05, 2.85 - 0.05), (1e-4, 1.5)]
    assert ParameterLayout.bounds[2] == (0.3, 2.5) and len(ParameterLayout.scales) == len(ParameterLayout.names) == 6


def test_a_workflow_rules_restricted_config_gives_the_parts_it_holds(config):
    """A rule hands its script only the keys it reads: the identifiability job's keys (the tyre's
    C alone, the means, the steering amplitude) give the same rank test as the whole config, and
    the parts the keys do not cover are None instead of an error at parse time."""
    from uqdrive.inference.identifiability import observability_analysis

    keys = ("vehicle", "tyre.C", "uncertainty.mu.mean", "uncertainty.m_load.mean", "uncertainty.l_f.mean", "uncertainty.F_w_mean",
            "steering.delta_max_deg")
    part = Settings.from_config(restrict_config(config, keys))
    assert part.vehicle.E is None and part.uncertainty.mu.std is None and part.time is None and part.ensemble_provenance is None
    whole = observability_analysis(Settings.from_config(config))
    assert observability_analysis(part).singular_values.tolist() == whole.singular_values.tolist()
    with pytest.raises(KeyError, match="lacks a key an ensemble reads"):
        part.ensemble_hash(10, 1)


@pytest.mark.parametrize("make", [lambda: Normal(1.0, -0.2), lambda: Normal(1.0, float("nan")), lambda: Uniform(400.0, -400.0),
                                  lambda: TimeGrid(10.0, 0.0, 0.005), lambda: TimeGrid(-1.0, 0.01, 0.005)])
def test_settings_refuse_what_no_config_means(make):
    with pytest.raises(ConfigError):
        make()
    assert Normal(1.0, 0.0).known == 1.0 and Uniform(5.0, 5.0).known == 5.0 and TimeGrid(1.0, 0.01, 0.005).substeps == 2

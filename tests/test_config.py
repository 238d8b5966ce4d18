import copy

import pytest
import yaml

from uqdrive.config import ConfigError, config_hash, load_config, validate_config

from conftest import REPO


def test_default_and_test_configs_validate():
    for name in ("config.yaml", "test.yaml"):
        cfg = load_config(REPO / "config" / name)
        assert cfg["vehicle"]["m_base"] == 1784.0


def test_default_config_holds_thesis_tables(config):
    # Table 5.1/5.2/5.3 and (5.5): spot checks of the transcribed numbers.
    assert config["vehicle"] == {
        "m_base": 1784.0, "J0": 0.84, "wheelbase": 2.85, "c_Sf": 10.6, "c_Sr": 30.4,
        "speed_kmh": 70.0, "M_c": -1.2, "g": 9.81,
    }
    assert config["uncertainty"]["mu"] == {"mean": 1.0, "std": 0.2}
    assert config["uncertainty"]["F_w_mean"] == {"low": -400.0, "high": 400.0}
    assert config["noise"]["levels"] == pytest.approx([0.01 * i for i in range(11)])
    assert config["montecarlo"]["samples"] == 2000
    assert config["wind"]["sigma"] == 100.0


@pytest.mark.parametrize(
    "mutate, key",
    [
        (lambda c: c["vehicle"].update(m_bse=1.0), "vehicle.m_bse"),
        (lambda c: c["vehicle"].update(m_base="heavy"), "vehicle.m_base"),
        (lambda c: c["vehicle"].update(m_base=-5.0), "vehicle.m_base"),
        (lambda c: c["montecarlo"].update(samples=1), "montecarlo.samples"),
        (lambda c: c["montecarlo"].update(spin_policy="drop"), "montecarlo.spin_policy"),
        (lambda c: c["uncertainty"]["mu"].update(std=-0.1), "uncertainty.mu.std"),
        (lambda c: c["uncertainty"]["F_w_mean"].update(low=500.0), "uncertainty.F_w_mean.low"),
        (lambda c: c["time"].update(step=0.003), "time.step"),
        (lambda c: c["uncertainty"]["l_f"].update(mean=3.0), "uncertainty.l_f.mean"),
        (lambda c: c.pop("seed"), "seed"),
    ],
)
def test_invalid_values_name_the_key(cfg, mutate, key):
    mutate(cfg)
    with pytest.raises(ConfigError, match=key.replace(".", r"\.")):
        validate_config(cfg)


def test_load_config_errors_are_config_errors(tmp_path):
    with pytest.raises(ConfigError, match="cannot read"):
        load_config(tmp_path / "missing.yaml")
    bad = tmp_path / "bad.yaml"
    bad.write_text("a: [1,\n")
    with pytest.raises(ConfigError, match="not valid YAML"):
        load_config(bad)


def test_config_hash_is_stable_and_sensitive(cfg):
    h = config_hash(cfg)
    assert h == config_hash(copy.deepcopy(cfg))
    assert h == config_hash(yaml.safe_load(yaml.safe_dump(cfg)))
    cfg["seed"] += 1
    assert config_hash(cfg) != h

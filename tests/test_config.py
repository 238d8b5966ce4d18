import copy
import re

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


def test_packaged_default_config_is_the_repository_config_searching_every_candidate():
    """The CLI's default (package data, so that it works from any folder and from a wheel) is the
    workflow's config/config.yaml with two lines apart: discover searches every registered
    candidate (``all``), the reproduction its own list; discover simulates ``model_samples``
    realisations on any file (ratio 0), the reproduction sizes them to its files' runs."""
    import importlib.util
    from importlib.resources import files

    from uqdrive.config import DEFAULT_CONFIG_NAME, default_config_text

    spec = importlib.util.spec_from_file_location("config_docs", REPO / "tools" / "config_docs.py")
    config_docs = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(config_docs)
    packaged = files("uqdrive").joinpath(DEFAULT_CONFIG_NAME).read_bytes()
    assert packaged.decode() == config_docs.packaged_default(), "config/config.yaml changed: run  python tools/config_docs.py"
    assert default_config_text().encode() == packaged
    default, repository = load_config(), load_config(REPO / "config" / "config.yaml")
    assert default["discrepancy"].pop("candidates") == "all" and repository["discrepancy"].pop("candidates") != "all"
    assert default["discrepancy"].pop("model_ratio") == 0 and repository["discrepancy"].pop("model_ratio") > 0
    assert default == repository


@pytest.mark.parametrize(
    "mutate, message",
    [
        (lambda c: c["time"].update(dt=float("nan")), "config key 'time.dt' is nan; give a finite number"),
        (lambda c: c["uncertainty"]["mu"].update(mean=float("inf")), "'uncertainty.mu.mean' is inf"),
        (lambda c: c["uncertainty"]["l_f"].update(std=float("-inf")), "'uncertainty.l_f.std' is -inf"),
        (lambda c: c["bayes"]["prior"].update(mu_mean=[0.05, float("nan")]), "'bayes.prior.mu_mean.1' is nan"),
        (lambda c: c["uncertainty"]["m_load"].update(mean=-1784.0), "'uncertainty.m_load.mean' = -1784 is outside the physical range [0, 100000] kg"),
        (lambda c: c["uncertainty"]["mu"].update(std=11.0), "'uncertainty.mu.std' = 11 is outside the physical range [0, 10]"),
        (lambda c: c["vehicle"].update(m_base=1e300), "'vehicle.m_base' = 1e+300"),
        (lambda c: c["vehicle"].update(speed_kmh=1e4), "'vehicle.speed_kmh'"),
        (lambda c: c["vehicle"].update(speed_kmh=0.0), "'vehicle.speed_kmh'"),
        (lambda c: c["time"].update(t_end=0.01), "'time.t_end' = 0.01 s must be at least 2 time.dt"),
        (lambda c: c["time"].update(step=-0.005), "'time.step'"),
        (lambda c: c["time"].update(dt=0.0), "'time.dt'"),
        (lambda c: c.update(seed=2**64), "'seed'"),
        (lambda c: c["montecarlo"].update(samples=1e300), "'montecarlo.samples'"),
        (lambda c: c["vehicle"].update({1: 2}), "is not a name"),
        (lambda c: c["time"].pop("dt"), "'time.dt' is missing; add it"),
        (lambda c: c["montecarlo"].update(spin_policy="drop"), "choose one of keep, exclude"),
        (lambda c: c["discrepancy"].update(model_ratio=-1), "'discrepancy.model_ratio'"),
        (lambda c: c["discrepancy"].update(model_ratio="ten"), "'discrepancy.model_ratio'"),
    ],
)
def test_physical_ranges_and_finite_numbers(cfg, mutate, message):
    mutate(cfg)
    with pytest.raises(ConfigError, match=re.escape(message)):
        validate_config(cfg)


def test_config_file_encoding_and_yaml_errors_are_one_line(tmp_path):
    latin = tmp_path / "latin.yaml"
    latin.write_bytes((REPO / "config" / "config.yaml").read_bytes() + "# Gr\xfc\xdfe\n".encode("latin-1"))
    with pytest.raises(ConfigError, match="is not UTF-8 text .*; save it as UTF-8"):
        load_config(latin)
    bad = tmp_path / "bad.yaml"
    bad.write_text("a: [1,\n")
    with pytest.raises(ConfigError) as err:
        load_config(bad)
    assert "\n" not in str(err.value)
    with pytest.raises(ConfigError, match="is not UTF-8|cannot read"):
        load_config(tmp_path)
    (tmp_path / "bom.yaml").write_bytes(b"\xef\xbb\xbf" + (REPO / "config" / "config.yaml").read_bytes())
    assert load_config(tmp_path / "bom.yaml")["seed"] == 20230601

"""config/README.md documents every config key and stays generated from the config, schema and rules."""

import importlib.util
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]
spec = importlib.util.spec_from_file_location("config_docs", ROOT / "tools" / "config_docs.py")
config_docs = importlib.util.module_from_spec(spec)
spec.loader.exec_module(config_docs)


def _leaves(d, prefix=""):
    for k, v in d.items():
        if isinstance(v, dict):
            yield from _leaves(v, f"{prefix}{k}.")
        else:
            yield f"{prefix}{k}"


def test_config_readme_is_up_to_date():
    assert (ROOT / "config" / "README.md").read_text() == config_docs.render(), "run: python tools/config_docs.py"


def test_every_config_leaf_has_a_row():
    documented = {row[0] for row in config_docs.commented_leaves((ROOT / "config" / "config.yaml").read_text())}
    assert set(_leaves(yaml.safe_load((ROOT / "config" / "config.yaml").read_text()))) == documented


def test_readers_and_constraints_are_read_from_rules_and_schema():
    readers = config_docs.rule_readers()
    assert "statistics" in config_docs.readers_of("montecarlo.spin_policy", readers)
    assert "fig_tyre_curves" in config_docs.readers_of("figures.tyre_surfaces.Snow.B", readers)
    schema = yaml.safe_load((ROOT / "src" / "uqdrive" / "config_schema.yaml").read_text())
    assert config_docs.schema_constraint(schema, "vehicle.m_base") == "number > 0"
    assert config_docs.schema_constraint(schema, "uncertainty.mu.std") == "number >= 0"

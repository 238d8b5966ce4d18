"""Shared fixtures: the repository's configs (validated) and small ensembles."""

import copy
from pathlib import Path

import pytest

from uqdrive.config import load_config

REPO = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="session")
def config():
    return load_config(REPO / "config" / "config.yaml")


@pytest.fixture
def cfg(config):
    """A mutable copy of the default config."""
    return copy.deepcopy(config)

"""The workflow's configuration as the command line reads a config: every file by the project's
YAML reader (YAML 1.2 numbers, a key given twice refused), merged as Snakemake merges them.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Sequence

from .config import merge_config, parse_overrides, read_config_mapping, validate_config

__all__ = ["workflow_config"]


def workflow_config(default: str | Path | None, configfiles: Sequence[str | Path] = (), overrides: Sequence[str] | None = ()) -> dict:
    """The validated config of a workflow run.

    Snakemake reads its ``configfile:`` and every ``--configfile`` with a YAML 1.1 loader
    (``1.573e3`` a string, a key given twice kept silently) and every nested ``--config`` leaf as a
    string. This rebuilds the config from the same sources in Snakemake's order, each read as
    the command line reads a config: the workflow's ``default`` file (None with
    ``--replace-workflow-config``), then each of ``configfiles`` merged on top key by key, then
    the ``overrides`` (``key=value`` entries, each value read as YAML: :func:`.config.parse_overrides`).

    Raises
    ------
    ConfigError
        If a file cannot be read, is not YAML or gives a key twice, or the merged config fails validation.
    """
    config: dict[str, Any] = {}
    for path in ([default] if default is not None else []) + list(configfiles):
        config = merge_config(config, read_config_mapping(path))
    return validate_config(merge_config(config, parse_overrides(overrides)))

"""The error of a refused configuration, shared by the config loader and the vehicle terms."""

from __future__ import annotations

__all__ = ["ConfigError"]


class ConfigError(ValueError):
    """A configuration value is missing, misspelt, of the wrong type or out of range."""

    __module__ = "uqdrive.config"

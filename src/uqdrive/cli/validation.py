"""Checks of the command-line flags, shared by every subcommand: each bad value is refused by
argparse with one line naming the flag, the value and the fix (exit code 2); what a flag sets up
in the process the command owns (JAX's disk cache of ``--device``)."""

from __future__ import annotations

import argparse
import importlib
import math
import os
import sys
from pathlib import Path

__all__ = ["OneLineParser", "finite_float", "bounded_int", "jobs_count", "device_choice", "compilation_cache", "stderr_line", "SEED_MAX"]

#: Largest root seed: netCDF stores it as a signed 64-bit attribute.
SEED_MAX = 2**63 - 1


class OneLineParser(argparse.ArgumentParser):
    """An ArgumentParser whose errors are one line on stderr (no usage block), exit code 2.

    Subparsers inherit the class, so every subcommand reports the same way.
    """

    def error(self, message: str):  # noqa: D102 (argparse API)
        """Print ``message`` as one line naming the help command and exit with status 2."""
        message = " ".join(str(message).split())
        self.exit(2, f"{self.prog}: error: {message} (see '{self.prog} --help')\n")


def finite_float(flag: str, low: float, high: float, unit: str = ""):
    """argparse type: a finite float in [low, high]."""
    unit = f" {unit}" if unit else ""

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{flag} '{text}' is not a number; give one in [{low:g}, {high:g}]{unit}") from None
        if not (math.isfinite(value) and low <= value <= high):
            raise argparse.ArgumentTypeError(f"{flag} {text} is outside [{low:g}, {high:g}]{unit}; give a finite value in that range")
        return value

    parse.__name__ = flag  # argparse names the type in some messages
    return parse


def bounded_int(flag: str, low: int, high: int, what: str = ""):
    """argparse type: an integer (written in decimal) in [low, high]."""
    what = f" ({what})" if what else ""

    def parse(text: str) -> int:
        try:
            value = int(text, 10)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{flag} '{text}' is not an integer; give one in {low}..{high}{what}") from None
        if not low <= value <= high:
            raise argparse.ArgumentTypeError(f"{flag} {text} is outside {low}..{high}{what}; give an integer in that range")
        return value

    parse.__name__ = flag
    return parse


def registry_choice(flag: str, module: str, registry: str):
    """argparse type: a key of the registry ``module.registry`` (lower case), looked up when the
    flag is parsed, so a cost or scale added to the registry is accepted without editing the CLI
    and commands that do not take the flag never import the module."""

    def parse(text: str) -> str:
        names = getattr(importlib.import_module(module), registry)
        if text.lower() not in names:
            raise argparse.ArgumentTypeError(f"{flag} '{text}' is unknown; choose one of {', '.join(names)}")
        return text.lower()

    parse.__name__ = flag
    return parse


def stderr_line(text: str) -> None:
    """Print ``text`` as exactly one line on stderr."""
    print(" ".join(str(text).split()), file=sys.stderr)


def jobs_count(text: str) -> int | str:
    """argparse type of ``--jobs``: a whole number of worker processes, at least 1, or ``auto``."""
    if text.strip().lower() == "auto":
        return "auto"
    try:
        value = int(text, 10)
    except ValueError:
        raise argparse.ArgumentTypeError(f"--jobs '{text}' is neither a whole number nor 'auto'; give e.g. --jobs 2 or --jobs auto") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"--jobs {text} is below 1; give a number of worker processes, 1 or more, or 'auto'")
    return value


def device_choice(text: str) -> str:
    """argparse type of ``--device``: a device this machine can run (:func:`uqdrive.numerics.backend.resolve_device`),
    with JAX's compiled programs kept on disk where it is JAX's (:func:`compilation_cache`:
    the next run loads what this one compiles)."""
    from ..numerics.backend import DEVICES, DeviceError, resolve_device

    try:
        if text in DEVICES and resolve_device(text) == "jax":  # an unknown name: argparse's choices name the known ones
            compilation_cache()
    except DeviceError as error:
        raise argparse.ArgumentTypeError(str(error)) from None
    return text


def compilation_cache(directory: str | Path | None = None) -> str:
    """Keep JAX's compiled programs on disk, so that a later process loads them instead of
    compiling anew (a four-wheel discover runs a few dozen programs: one per combination of terms,
    tyre and size, :mod:`uqdrive.vehicle.accelerated.chassis_ensemble`); a process that already
    names a cache (``JAX_COMPILATION_CACHE_DIR`` or JAX's config) keeps its own. For the command
    line, which owns its process: the setting is JAX's, global.

    Parameters
    ----------
    directory : path, optional
        Where to keep them; default ``$XDG_CACHE_HOME/uqdrive/jax`` (``~/.cache/uqdrive/jax``).

    Returns
    -------
    str
        The cache directory in use.
    """
    import jax

    current = jax.config.jax_compilation_cache_dir
    if current:
        return str(current)
    if directory is None:
        directory = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "uqdrive" / "jax"
    jax.config.update("jax_compilation_cache_dir", str(directory))
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.0)  # every program: each is compiled once per search
    return str(directory)

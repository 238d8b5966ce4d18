"""The `uqdrive` command line: `simulate`, `identify` (and their argument parsing)."""

from .main import main

__all__ = ["main"]

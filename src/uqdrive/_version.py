"""The installed version of uqdrive, for provenance attributes (one place, no import cycle)."""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("uqdrive")
except PackageNotFoundError:  # running from a source tree without installation
    __version__ = "0+unknown"

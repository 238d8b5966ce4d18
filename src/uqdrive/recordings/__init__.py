"""Recorded test drives in: MDF4, CSV and MATLAB logs of one run each, read, converted to SI units,
resampled, aligned by their steering and written as one ensemble of the data schema.
"""

from typing import TYPE_CHECKING

from .._lazy import lazy_exports

if TYPE_CHECKING:  # static analysers and the import graph see the real imports
    from .channel_map import ChannelMap, read_channel_map  # noqa: F401
    from .importer import import_runs  # noqa: F401
    from .readers import Recording, read_recording  # noqa: F401

__getattr__, __dir__ = lazy_exports(__name__, {
    "ChannelMap": ".channel_map",
    "read_channel_map": ".channel_map",
    "import_runs": ".importer",
    "Recording": ".readers",
    "read_recording": ".readers",
})

__all__ = ["ChannelMap", "Recording", "import_runs", "read_channel_map", "read_recording"]

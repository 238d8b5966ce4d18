"""Sensor candidate effects: a constant offset or a gain error on one measured channel, one
registry entry per channel (the states and the lateral acceleration).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from ..single_track import STATES
from .structure import Effect

__all__ = ["SensorBias", "SensorScale", "SENSOR_CHANNELS", "channel_effects"]


@dataclass(frozen=True)
class SensorBias(Effect):
    """Constant offset on one measured channel, in that channel's unit."""

    channel: str = "psi"

    @property
    def vanishes(self) -> tuple:
        """(parameter, value) where the bias vanishes: the channel's offset 0."""
        return (f"offset_{self.channel}", 0.0)

    def apply(self, s, v):
        """``s`` with the channel's offset ``v[0]`` (its unit)."""
        if self.channel == "a_y":
            return replace(s, a_y_offset=float(v[0]))
        offset = list(s.output_offset)
        offset[STATES.index(self.channel)] = float(v[0])
        return replace(s, output_offset=tuple(offset))


@dataclass(frozen=True)
class SensorScale(Effect):
    """Gain error (-) of one measured channel's sensor."""

    channel: str = "psi"

    @property
    def vanishes(self) -> tuple:
        """(parameter, value) where the gain error vanishes: the channel's gain 1."""
        return (f"gain_{self.channel}", 1.0)

    def apply(self, s, v):
        """``s`` with the channel's gain ``v[0]`` (-)."""
        if self.channel == "a_y":
            return replace(s, a_y_gain=float(v[0]))
        gain = list(s.output_gain)
        gain[STATES.index(self.channel)] = float(v[0])
        return replace(s, output_gain=tuple(gain))


_BIAS_BOUND = {"psi": 0.2, "psi_dot": 0.2, "beta": 0.05, "y": 5.0, "a_y": 2.0}
#: Channels a sensor effect can act on: the four states and the lateral acceleration (m/s^2).
SENSOR_CHANNELS = STATES + ("a_y",)
_UNITS = {"psi": "rad", "psi_dot": "rad/s", "beta": "rad", "y": "m", "a_y": "m/s^2"}


def channel_effects(kind: str) -> dict[str, Effect]:
    """One sensor effect per measured channel, named ``<kind>_<channel>``."""
    out = {}
    for ch in SENSOR_CHANNELS:
        if kind == "sensor_bias":
            b = _BIAS_BOUND[ch]
            out[f"sensor_bias_{ch}"] = SensorBias(
                f"sensor_bias_{ch}", (f"offset_{ch}",), (_UNITS[ch],),
                ((-b, b),), (0.0,), f"constant offset on the measured {ch}",
                f"{ch}: mean shifted by a constant at every time, std unchanged, other channels untouched", channel=ch)
        else:
            out[f"sensor_scale_{ch}"] = SensorScale(
                f"sensor_scale_{ch}", (f"gain_{ch}",), ("-",), ((0.5, 2.0),), (1.0,), f"gain error of the {ch} sensor",
                f"{ch}: mean and std scaled by the same factor, other channels untouched", channel=ch)
    return out

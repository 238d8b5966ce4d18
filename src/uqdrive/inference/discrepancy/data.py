"""The measured ensemble as the discrepancy workflow compares it: whichever channels the file
carries, on an evenly thinned time grid, with the noise level of each channel and the runs that
lost control set aside.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ...settings import Spin
from ...vehicle.channels import CHANNELS
from ...vehicle.noise import estimate_noise_variance

__all__ = ["Measured", "prepare_measured", "speed_profile"]


class Measured(NamedTuple):
    """Measured channels (C, n, K + 1) on the compared grid, compared indices (K,), noise
    variance per channel (C,), spin threshold (rad, or None), channel names, stride, indices of
    the runs that lost control, runs used."""

    x: np.ndarray; index: np.ndarray; noise: np.ndarray; spin: float | None; channels: tuple; stride: int  # noqa: E702
    spun: np.ndarray; samples_used: int  # noqa: E702


def prepare_measured(ds, spin_policy: Spin, max_times: int) -> Measured:
    """The channels of :data:`uqdrive.vehicle.channels.CHANNELS` that ``ds`` carries, every
    ``stride`` samples from t = 0 (at most ``max_times`` compared times, t = 0 left out), each
    channel's noise variance (:func:`uqdrive.vehicle.noise.estimate_noise_variance`), and the
    spin policy ``spin_policy`` (threshold in rad, keep or exclude). Without beta the
    data cannot tell which runs spun: every run is used and no model realisation is left out
    (spin None).
    """
    channels = tuple(c for c in CHANNELS if c in ds)
    x = np.stack([np.asarray(ds[s].values, float) for s in channels])  # (C, n, T)
    thr = float(spin_policy.threshold)
    has_beta = "beta" in channels
    spun = np.any(np.abs(x[channels.index("beta")]) > thr, axis=-1) if has_beta else np.zeros(x.shape[1], bool)
    exclude = has_beta and spin_policy.policy == "exclude"
    used = ~spun if exclude else np.ones_like(spun)
    T = x.shape[-1]
    stride = max(1, int(np.ceil((T - 1) / max_times)))
    K = (T - 1) // stride
    noise = np.array([estimate_noise_variance(x[i, used], order=4) for i in range(len(channels))])
    return Measured(x[:, used][:, :, : K * stride + 1 : stride], np.arange(1, K + 1), noise, thr if exclude else None, channels, stride,
                    np.flatnonzero(spun), int(used.sum()))


def speed_profile(ds):
    """The data's speed over time (m/s) when it changes (the mean over runs of a ``v`` over
    (sample, time)), None for a constant speed (``v_c``, or a ``v`` that never changes)."""
    if "v" not in ds:
        return None
    v = np.asarray(ds["v"].values, float)
    v = v.mean(axis=0) if v.ndim == 2 else v
    return None if np.all(v == v[0]) else v

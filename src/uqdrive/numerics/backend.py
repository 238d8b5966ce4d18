"""Where an ensemble is computed: the NumPy path on the CPU or JAX on a GPU, chosen by a device
name ("auto", "cpu", "gpu"); JAX is optional and imported only when a GPU is asked for or sought.
"""

from __future__ import annotations

import importlib.util

from .._errors import ConfigError

__all__ = ["DEVICES", "GPU_INSTALL", "DeviceError", "jax_installed", "gpu_visible", "resolve_device", "float64"]

#: The device names a caller may choose: auto (a GPU when JAX sees one, else the CPU), cpu, gpu.
DEVICES = ("auto", "cpu", "gpu")
#: The install command of the GPU backend, named in every refusal.
GPU_INSTALL = 'pip install "uqdrive[gpu]"'


class DeviceError(ConfigError):
    """The device asked for cannot run here: JAX is missing or sees no GPU."""

    __module__ = "uqdrive.numerics.backend"


def jax_installed() -> bool:
    """Whether the ``jax`` package can be imported (found without importing it)."""
    return importlib.util.find_spec("jax") is not None


def gpu_visible() -> bool:
    """Whether JAX is installed and sees at least one GPU (imports jax when installed)."""
    if not jax_installed():
        return False
    import jax

    try:
        return len(jax.devices("gpu")) > 0
    except RuntimeError:  # no GPU backend in this jaxlib, or no driver: JAX refuses the platform
        return False


def resolve_device(device: str) -> str:
    """The path that computes for the device name ``device``.

    Parameters
    ----------
    device : {"auto", "cpu", "gpu"}
        cpu: the NumPy reference; gpu: JAX on a GPU, refused when there is none; auto: the GPU
        when JAX is installed and sees one, else the NumPy path.

    Returns
    -------
    str
        "numpy" or "jax".

    Raises
    ------
    DeviceError
        For an unknown name, or "gpu" without JAX or without a GPU it can see (one line naming
        the fix).
    """
    if device not in DEVICES:
        raise DeviceError(f"device '{device}' is unknown; choose one of {', '.join(DEVICES)}")
    if device == "cpu":
        return "numpy"
    if device == "auto":
        return "jax" if gpu_visible() else "numpy"
    if not jax_installed():
        raise DeviceError(f"device 'gpu' needs JAX, which is not installed; install it with {GPU_INSTALL} or choose device cpu")
    if not gpu_visible():
        raise DeviceError(f"device 'gpu': JAX sees no GPU (a CPU-only jaxlib, or no CUDA driver); install the CUDA build "
                          f"with {GPU_INSTALL} or choose device cpu")
    return "jax"


def float64():
    """A context in which JAX computes in float64 (``jax_enable_x64`` for its extent only), so
    that uqdrive does not change the precision of a caller's other JAX code.

    Returns
    -------
    contextlib.AbstractContextManager
        ``jax.enable_x64(True)``, or ``jax.experimental.enable_x64()`` on JAX releases before it.
    """
    import jax

    scoped = getattr(jax, "enable_x64", None)
    if scoped is not None:
        return scoped(True)
    from jax.experimental import enable_x64  # pragma: no cover - JAX releases before jax.enable_x64

    return enable_x64()


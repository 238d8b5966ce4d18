"""RK4 passes of the single-track model with chassis effects in JAX (float64): one compiled scan
over the steps, the realisations as the vector axis, the inputs formed on the device.

A pass sends the device the realisations' constants, mean wind and gust mode coefficients and the
grid's KLE eigenfunctions and steering, and forms the gusts F_w = F_w_mean + c f(t) of (5.1),
(5.21) at each half step there (no (J, n) wind table crosses the bus, which at a discover's few
thousand realisations would be most of a pass's traffic); the lateral acceleration a_y of the
recorded states is computed there too. A program holds the terms its pass has on, and its
realisations are padded to a power of two, on an accelerator to at least
:data:`ACCELERATOR_MIN_WIDTH`, so that passes of other sizes share one (:func:`programs_compiled`).
``share_programs`` instead holds the load and compliance terms in every program (:data:`SWITCHED`):
fewer programs to compile, but several times the fused kernels per RK4 step in a pass without them
(``benchmarks/bench_chassis_programs.py`` counts them).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from ...numerics.backend import float64
from .chassis import chassis_constants, chassis_lateral_acceleration, chassis_rates
from .rk4 import per_step, rk4_rows_step

__all__ = ["SWITCHED", "ACCELERATOR_MIN_WIDTH", "switched_on", "program_width", "integrate_chassis_jax", "programs_compiled"]

#: Terms a shared program holds (``share_programs``), whether a pass has them on or not: off, their
#: constants are zero (no load moved, unit shares and factors, no yield), which gives the doubles
#: of a program without them, so the passes of a search share programs by tyre, relaxation, roll
#: steer and speed alone (a dry run of fw_slalom_090's 858 passes: 19 programs where one per
#: combination of terms needs 45). The price is in every step: the loads' Newton loop and the
#: yield's, unrolled, split a step into several times the fused kernels, each a launch on a GPU.
SWITCHED = ("loaded", "pitching", "transferring", "slipping", "sensitive", "compliant")


def switched_on(c: dict, f: dict) -> tuple[dict, dict]:
    """The constants and flags of :func:`.chassis.chassis_constants` with every :data:`SWITCHED` term
    on: a term that was off has zero constants already (no pitch height, load sensitivity, slip
    share, tyre factors or compliance), but the lateral arm h / t is the car's even where no load
    moves (the right-hand side then never computes the loads), so it is zeroed there."""
    c = dict(c)
    if not f["loaded"]:
        c["arm"] = np.zeros_like(c["arm"])
    return c, {**f, **dict.fromkeys(SWITCHED, True)}


#: The static choices and shapes of the programs this process ran: one program each (compiled, or
#: loaded from JAX's disk cache, at its first pass).
_PROGRAMS: set = set()


def programs_compiled() -> int:
    """How many programs this process's passes needed (each compiled or loaded from disk once)."""
    return len(_PROGRAMS)


def _ensemble(c, wind_mean, coeffs, delta, modes, speed, h, v_c, f_items: tuple, n_states: int, acceleration: bool):
    """States (K + 1, d, n) by RK4 from rest and, with ``acceleration``, a_y (K + 1, n) (else None):
    ``delta`` (K, R, 3, n) or (K, R, 3, 1) (one angle for all), ``modes`` (K, R, 3, n_c), ``speed``
    (K, R, 3, 2) or None: each step's inputs at its start, middle and end."""
    import jax.numpy as jnp
    from jax import lax

    f = dict(f_items)
    columns = [coeffs[:, i] for i in range(coeffs.shape[1])]

    def inputs_at(inputs, k):  # delta, F_w, v, v_dot at a step's start (0), middle (1), end (2)
        modes_k = inputs[1][k]
        gust = columns[0] * modes_k[0]
        for i in range(1, len(columns)):  # unrolled: the sums fuse with the right-hand side
            gust = gust + columns[i] * modes_k[i]
        v, v_dot = (v_c, 0.0) if speed is None else (inputs[2][k][0], inputs[2][k][1])
        return inputs[0][k], wind_mean + gust, v, v_dot

    def stage(x, inputs, k):
        return chassis_rates(c, f, x, *inputs_at(inputs, k))

    def step(x, inputs):
        return rk4_rows_step(stage, x, inputs, h), None

    def recorded(x, inputs, k):
        a_y = chassis_lateral_acceleration(c, f, x, *inputs_at(inputs, k)) if acceleration else jnp.zeros(0)
        return jnp.stack(x[:4]), a_y

    def interval(x, inputs):
        x, _ = lax.scan(step, x, inputs)
        return x, recorded(x, tuple(a[-1] for a in inputs), 2)  # the last step's end: the recorded time

    rows = tuple(jnp.zeros_like(wind_mean) for _ in range(n_states))
    step_inputs = (delta, modes) if speed is None else (delta, modes, speed)
    start = recorded(rows, tuple(a[0, 0] for a in step_inputs), 0)
    _, (states, a_y) = lax.scan(interval, rows, step_inputs)
    return jnp.concatenate([start[0][None], states]), (jnp.concatenate([start[1][None], a_y]) if acceleration else None)


@lru_cache(maxsize=None)
def _compiled():
    """The jitted ensemble (compiled once per shape and combination of terms)."""
    import jax

    return jax.jit(_ensemble, static_argnames=("f_items", "n_states", "acceleration"))


#: Fewest realisations a program is compiled for on an accelerator: a pass of fewer is bound by
#: the launches of its kernels, not by their arithmetic (the NLST program's 2000 and 20 000 runs
#: took 17.8 and 20 ms on an H200, docs/measurements/gpu.json), so one width serves a search's
#: passes of a few hundred to a few thousand realisations (the dry runs of fw_step_060 and
#: fw_slalom_090: 26 and 28 programs where a power of two from 8 up needs 32 and 45).
ACCELERATOR_MIN_WIDTH = 8192


def program_width(n: int, accelerator: bool = False) -> int:
    """Realisations a program for ``n`` is compiled for: the next power of two, at least 8, on an
    accelerator at least :data:`ACCELERATOR_MIN_WIDTH`."""
    return max(ACCELERATOR_MIN_WIDTH if accelerator else 8, 1 << (int(n) - 1).bit_length())


def integrate_chassis_jax(rhs, h: float, n_steps: int, record_every: int, wind_mean, coeffs, eigenfunctions_half,
                          lateral_acceleration: bool = False, share_programs: bool = False):
    """The states of :func:`uqdrive.vehicle.track_extended.integrate_chassis` by JAX on its default
    device, and the lateral acceleration a_y of the recorded states.

    Parameters
    ----------
    rhs : ExtendedSingleTrackRHS
        The NumPy right-hand side: its constants, steering (and speed) on the half-step grid
        (2 ``n_steps`` + 1 points) are integrated here; its wind table ``F_w_half`` is not read
        (None will do).
    h, n_steps, record_every
        RK4 step (s), steps and the stride of the returned states, as
        :func:`uqdrive.vehicle.track_rk4.integrate_single_track` takes them.
    wind_mean : ndarray, shape (n,)
        Mean side wind (N).
    coeffs : ndarray, shape (n, n_c)
        Gust mode coefficients (N), the gusts scaled already.
    eigenfunctions_half : ndarray, shape (n_c, 2 n_steps + 1)
        KLE eigenfunctions (-) on the half-step grid: F_w = ``wind_mean`` + ``coeffs`` f(t).
    lateral_acceleration : bool
        Also a_y (:meth:`~uqdrive.vehicle.track_extended.ExtendedSingleTrackRHS.lateral_acceleration`).
    share_programs : bool
        Run the program that holds every :data:`SWITCHED` term (the same doubles; fewer programs
        per search, more kernels per step) instead of the one of this pass's terms.

    Returns
    -------
    states : ndarray, shape (n_steps // record_every + 1, 4, n)
        psi, psi_dot, beta, y (rad, rad/s, rad, m) every ``record_every`` steps from t = 0.
    a_y : ndarray, shape (n, n_steps // record_every + 1), or None
        Lateral acceleration (m/s^2) at the same times, where asked for.
    """
    if n_steps % record_every:
        raise ValueError("n_steps must be a multiple of record_every")
    wind_mean, coeffs = np.asarray(wind_mean, float), np.asarray(coeffs, float).reshape(np.size(wind_mean), -1)
    n, J = wind_mean.shape[0], 2 * n_steps + 1
    c, f = chassis_constants(rhs, n)
    if share_programs:
        c, f = switched_on(c, f)
    import jax

    width = program_width(n, jax.default_backend() != "cpu")
    pad = lambda a: np.concatenate([a, np.repeat(a[..., -1:], width - n, axis=-1)], axis=-1) if width > n else a  # noqa: E731
    delta = np.asarray(rhs.delta_half, float)[:J].reshape(J, -1)  # (J, 1): one angle for all, broadcast on the device
    delta = pad(delta) if delta.shape[1] > 1 else delta
    modes = np.ascontiguousarray(np.asarray(eigenfunctions_half, float)[:, :J].T)  # (J, n_c)
    speed = None
    if rhs.speed_half is not None:
        speed = per_step(np.stack([np.asarray(a, float)[:J] for a in rhs.speed_half], axis=-1), n_steps, record_every)
    static = tuple(sorted(f.items()))
    _PROGRAMS.add((static, width, delta.shape[1] > 1, n_steps, record_every, rhs.n_states, bool(lateral_acceleration)))
    with float64():
        args = jax.device_put(({k: pad(a) for k, a in c.items()}, pad(wind_mean), pad(coeffs.T).T, per_step(delta, n_steps, record_every),
                               per_step(modes, n_steps, record_every), speed, float(h), float(rhs.v)))
        states, a_y = _compiled()(*args, f_items=static, n_states=rhs.n_states, acceleration=bool(lateral_acceleration))
        # cut the padding on the device: only the n realisations cross the bus
        return np.asarray(states[:, :, :n]), (None if a_y is None else np.asarray(a_y[:, :n]).T)

"""The NLST ensemble (thesis (5.3)) by RK4 in JAX: one compiled scan over time with the
realisations as the vector axis, the operations of the NumPy path in the same order (float64).

The right-hand sides repeat :class:`uqdrive.vehicle.dynamics.rhs.SingleTrackRHS` (constant speed: its
balances multiplied by the inverses; a speed profile: divided, ``quotient``, with the speed term of
:meth:`uqdrive.vehicle.dynamics.engine.EnsembleSimulator.driven`) operation for operation, and
the stepper repeats :func:`uqdrive.numerics.integrate.rk4_fixed_step_into`: the two paths differ
by the last bits of the transcendental functions, of the gusts' sums and of the multiply-adds a
compiler fuses, nothing else.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from ...numerics.backend import float64
from ...settings import TimeGrid
from ..single_track import VehicleParameters
from .rk4 import per_step, rk4_rows_step

__all__ = ["nlst_program", "simulate_nlst_jax"]


def _curved_slip_force(peak, stiffness, slip, C, E):
    """peak sin(C atan(u)) with u = B x - E (B x - atan(B x)), B x = ``stiffness * slip``: the
    Magic Formula (2.2a) in :func:`uqdrive.vehicle.single_track.curvature_argument`'s order."""
    import jax.numpy as jnp

    bx = stiffness * slip
    u = bx - (bx - jnp.arctan(bx)) * E
    return peak * jnp.sin(C * jnp.arctan(u))


def _rhs_constant_speed(q, x, delta, F_w, M_w):
    """dx/dt of (5.3) at the constant speed q["v"]: :class:`~uqdrive.vehicle.dynamics.rhs.SingleTrackRHS`'s operations; ``x``
    and the result are tuples of the four states' arrays (n,)."""
    import jax.numpy as jnp

    psi, psi_dot, beta, _ = x
    v = q["v"]
    sin_b, cos_b = jnp.sin(beta), jnp.cos(beta)
    vy, vx = v * sin_b, v * cos_b
    slip_f = -jnp.arctan((vy + q["l_f"] * psi_dot) / vx) + delta
    slip_r = -jnp.arctan((vy + q["minus_l_r"] * psi_dot) / vx)
    F_f = _curved_slip_force(q["peak_f"], q["c_Sf"], slip_f, q["C"], q["E"])
    F_r = _curved_slip_force(q["peak_r"], q["c_Sr"], slip_r, q["C"], q["E"])
    F_fy_cos = F_f * jnp.cos(delta)
    psi_ddot = (q["l_f"] * F_fy_cos - q["l_r"] * F_r + M_w) * q["inv_I_z"]
    beta_dot = (F_fy_cos + F_r + F_w) * cos_b * q["inv_mv"] - psi_dot
    return psi_dot, psi_ddot, beta_dot, v * jnp.sin(psi)


def _rhs_speed_profile(q, x, delta, F_w, M_w, v, v_dot):
    """dx/dt of (5.3) at the speed v (m/s) changing at v_dot (m/s^2): the operations of
    :class:`~uqdrive.vehicle.dynamics.rhs.SingleTrackRHS` with ``quotient`` and the speed term, as
    :meth:`~uqdrive.vehicle.dynamics.engine.EnsembleSimulator.driven` integrates it."""
    import jax.numpy as jnp

    psi, psi_dot, beta, _ = x
    vy, vx = v * jnp.sin(beta), v * jnp.cos(beta)
    alpha_f = delta - jnp.arctan((vy + q["l_f"] * psi_dot) / vx)
    alpha_r = -jnp.arctan((vy - q["l_r"] * psi_dot) / vx)
    F_fy = _curved_slip_force(q["peak_f"], q["c_Sf"], alpha_f, q["C"], q["E"])
    F_ry = _curved_slip_force(q["peak_r"], q["c_Sr"], alpha_r, q["C"], q["E"])
    F_fy_cos = F_fy * jnp.cos(delta)
    psi_ddot = (q["l_f"] * F_fy_cos - F_ry * q["l_r"] + M_w) / q["I_z"]
    beta_dot = (F_fy_cos + F_ry + F_w) * jnp.cos(beta) / (q["m"] * v) - psi_dot
    beta_dot = beta_dot - v_dot / v * jnp.sin(beta)
    return psi_dot, psi_ddot, beta_dot, jnp.sin(psi) * v


def _ensemble(q, coeffs, wind_mean, delta, modes, speed, h, gust_yaw_moment: bool, unroll: int):
    """States (4, n, n_out + 1) of the RK4 recursion; ``delta`` (n_out, S, 3), ``modes``
    (n_out, S, 3, n_c) and ``speed`` (n_out, S, 3, 2) or None hold each step's inputs at its
    start, middle and end (the half-step grid's j, j + 1, j + 2).

    The state is carried as four arrays (n,), not one (4, n): stacking and slicing a (4, n) array
    at every stage splits each step into more GPU kernels (twice the time on an H100)."""
    import jax.numpy as jnp
    from jax import lax

    columns = [coeffs[:, c] for c in range(coeffs.shape[1])]

    def stage(x, inputs, k):
        d, f = inputs[0][k], inputs[1][k]
        gust = columns[0] * f[0]
        for c in range(1, len(columns)):  # unrolled: the sums fuse with the right-hand side
            gust = gust + columns[c] * f[c]
        F_w = wind_mean + gust
        M_w = q["M_c"] * F_w if gust_yaw_moment else q["M_c"] * wind_mean
        if speed is None:
            return _rhs_constant_speed(q, x, d, F_w, M_w)
        v = inputs[2][k]
        return _rhs_speed_profile(q, x, d, F_w, M_w, v[0], v[1])

    def step(x, inputs):
        return rk4_rows_step(stage, x, inputs, h), None

    def interval(x, inputs):
        x, _ = lax.scan(step, x, inputs, unroll=True)
        return x, jnp.stack(x)

    zero = jnp.zeros_like(wind_mean)
    step_inputs = (delta, modes) if speed is None else (delta, modes, speed)
    _, states = lax.scan(interval, (zero,) * 4, step_inputs, unroll=unroll)  # (n_out, 4, n)
    return jnp.concatenate([jnp.zeros((1,) + states.shape[1:], states.dtype), states]).transpose(1, 2, 0)


@lru_cache(maxsize=None)
def _compiled():
    """The jitted ensemble (compiled once per shape and static choice)."""
    import jax

    return jax.jit(_ensemble, static_argnames=("gust_yaw_moment", "unroll"))


def _parameters(p: VehicleParameters, n: int, constant_speed: bool) -> dict:
    """Per-realisation arrays (n,) and scalars of the right-hand side, computed by NumPy with the
    expressions of the NumPy path (so that both start from the same doubles)."""
    shape = (n,)
    l_f = np.broadcast_to(np.asarray(p.l_f, float), shape)
    l_r = np.broadcast_to(p.l_r, shape)
    q = {"l_f": l_f, "l_r": l_r, "c_Sf": p.c_Sf, "c_Sr": p.c_Sr, "C": p.C, "E": p.E, "M_c": p.M_c,
         "peak_f": np.broadcast_to(p.F_fz * p.mu, shape), "peak_r": np.broadcast_to(p.F_rz * p.mu, shape)}
    if constant_speed:
        v = float(p.v_c)
        q.update(v=v, minus_l_r=-l_r, inv_I_z=1.0 / np.broadcast_to(p.I_z, shape), inv_mv=1.0 / np.broadcast_to(p.m * v, shape))
    else:
        q.update(I_z=np.broadcast_to(p.I_z, shape), m=np.broadcast_to(p.m, shape))
    return {k: np.asarray(val, float) for k, val in q.items()}


def nlst_program(p: VehicleParameters, delta_half, wind_mean, wind_coeffs, eigenfunctions_half, grid: TimeGrid,
                 gust_yaw_moment: bool = True, speed_half=None, unroll: int = 1):
    """The compiled ensemble and its arguments on JAX's default device, to be called inside
    :func:`uqdrive.numerics.backend.float64`: ``function(*args)`` returns the states of
    :func:`simulate_nlst_jax` as a device array (for timing without the copy to the host).

    Parameters
    ----------
    p, delta_half, wind_mean, wind_coeffs, eigenfunctions_half, grid, gust_yaw_moment, speed_half
        As for :func:`simulate_nlst_jax`.
    unroll : int
        Output intervals per iteration of the compiled loop (a tuning knob; the numbers do not
        depend on it).

    Returns
    -------
    function : callable
        The jitted ensemble with its static choices bound.
    args : tuple
        Its arguments, already on the device: the parameters (arrays of shape (n,) and scalars),
        the wind coefficients (n, n_c), the mean wind (n,), each step's steering (n_out, S, 3),
        KLE modes (n_out, S, 3, n_c) and speed (n_out, S, 3, 2) or None, and the step h (s).
    """
    import jax

    wind_mean = np.asarray(wind_mean, float)
    n = wind_mean.shape[0]
    q = _parameters(p, n, speed_half is None)
    n_steps = grid.n_out * grid.substeps
    modes = per_step(np.asarray(eigenfunctions_half, float).T, n_steps, grid.substeps)
    speed = None
    if speed_half is not None:
        v_half = np.asarray(speed_half, float)
        speed = per_step(np.stack([v_half, np.gradient(v_half, grid.step / 2.0)], axis=-1), n_steps, grid.substeps)
    delta = per_step(delta_half, n_steps, grid.substeps)
    args = jax.device_put((q, np.asarray(wind_coeffs, float), wind_mean, delta, modes, speed, float(grid.step)))
    jitted = _compiled()

    def function(*a):
        return jitted(*a, gust_yaw_moment=bool(gust_yaw_moment), unroll=int(unroll))

    function.lower = lambda *a: jitted.lower(*a, gust_yaw_moment=bool(gust_yaw_moment), unroll=int(unroll))
    return function, args


def simulate_nlst_jax(p: VehicleParameters, delta_half, wind_mean, wind_coeffs, eigenfunctions_half, grid: TimeGrid,
                      gust_yaw_moment: bool = True, speed_half=None):
    """The Monte Carlo NLST ensemble of :meth:`uqdrive.vehicle.dynamics.engine.EnsembleSimulator.driven`
    (at constant speed, ``speed_half`` None, or along a speed profile) computed by JAX on its default device.

    The arguments, their shapes and units are those of the NumPy path; ``speed_half``
    (shape (2 n_fine - 1,), m/s) is the speed on the half-step grid, None for ``p.v_c``.
    Returns the states on the output grid, shape (4, n, n_out + 1), float64, as it does.
    """
    with float64():
        function, args = nlst_program(p, delta_half, wind_mean, wind_coeffs, eigenfunctions_half, grid, gust_yaw_moment, speed_half)
        return np.asarray(function(*args))

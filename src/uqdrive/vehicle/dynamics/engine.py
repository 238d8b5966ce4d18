"""The one ensemble simulator of the single-track model: n realisations, given by their
parameters, mean wind and gust modes, with a structure's effects, on a sampled input grid.

Linear structures at constant speed are discretised exactly (first-order hold,
:func:`uqdrive.vehicle.dynamics.ensemble.exact_response`); a non-linear tyre, the chassis terms
and a speed profile are integrated by vectorised RK4 (:class:`uqdrive.vehicle.dynamics.rhs.SingleTrackRHS`,
:func:`uqdrive.vehicle.track_extended.integrate_chassis`, :class:`uqdrive.vehicle.track_rk4.LinearTrackRHS`).
:class:`uqdrive.vehicle.augmented.AugmentedSimulator` draws the realisations from fixed germs and
distribution parameters; the Monte Carlo data sets are simulated here too, the NLST on inputs
evaluated at the RK4 half steps (:class:`HalfStepDrive`, :meth:`EnsembleSimulator.driven`).
"""

from __future__ import annotations

import threading
from dataclasses import dataclass, replace

import numpy as np

from ...numerics.integrate import cumulative_trapezoid
from ...numerics.sampled_input import actual_steering, checked_interpolation, held_index, held_integral
from ...settings import Settings, TimeGrid
from ..effects import ModelStructure, with_tyre_shape
from ..single_track import STATES, VehicleParameters, lst_matrices, with_compliance_steer
from ..track_extended import chassis_rhs, integrate_chassis
from ..track_rk4 import (LinearTrackRHS, integrate_linear_ltv, integrate_single_track, linear_lateral_acceleration, measured_channels,
                         rk4_lateral_acceleration, speed_on_half_steps)
from ..uncertainty import KarhunenLoeve, kle_of_wind
from .ensemble import exact_response, simulate_lst_ltv
from .rhs import GustInputs, HalfStepInputs, SingleTrackRHS

__all__ = ["RK4_MAX_STEP", "GUST_PRODUCTS", "GUST_BYTES", "HalfStepDrive", "EnsembleSimulator"]

#: The longest RK4 step (s): stable (|h lambda| < 0.5) and within 1e-4 of the 5 ms reference.
RK4_MAX_STEP = 0.01
#: Gust products kept per simulator (:meth:`EnsembleSimulator._gusts`; 16 MB each at 1000
#: realisations and 2000 half steps), and the size past which a product is not kept.
GUST_PRODUCTS, GUST_BYTES = 4, 40_000_000


@dataclass(frozen=True, eq=False)
class HalfStepDrive:
    """Inputs the caller evaluates at every RK4 half step of the grid's own step, for analytic
    inputs (the thesis ensembles' sine steering, KLE eigenfunctions and speed ramp): RK4 then
    steps at ``step`` and reads these values, where a sampled input is reconstructed between
    its samples and integrated at :data:`RK4_MAX_STEP`.

    Parameters
    ----------
    step : float
        RK4 step (s): the simulator's grid step.
    steering : ndarray, shape (J,)
        Actual front wheel angle (rad) at the half steps j ``step`` / 2, J = 2 (T - 1) + 1.
    eigenfunctions : ndarray, shape (n_c, J)
        KLE eigenfunctions (-) at the half steps.
    speed : tuple of two ndarrays, shape (J,), optional
        Speed v (m/s) and its rate v_dot (m/s^2) at the half steps; None: the constant speed.
    gusts_per_step : bool
        Form the gusts F_w_mean + c f(t_j) at each half step as they are needed
        (:class:`~uqdrive.vehicle.dynamics.rhs.GustInputs`: no (J, n) table in memory, the
        rounding of the Monte Carlo data sets), else as the table ``c @ f_half`` once.
    quotient : bool
        The balances divide by I_z and m v (the rounding of the data sets along a speed
        profile, :class:`~uqdrive.vehicle.dynamics.rhs.Balance`).
    """

    step: float
    steering: np.ndarray
    eigenfunctions: np.ndarray
    speed: tuple | None = None
    gusts_per_step: bool = True
    quotient: bool = False


class _Recorded:
    """The a_y (n, K + 1) of a pass that computed it with its states (the JAX passes), in the place
    of a right-hand side for :func:`~uqdrive.vehicle.track_rk4.rk4_lateral_acceleration`."""

    def __init__(self, a_y):
        self.a_y = a_y

    def lateral_acceleration_along(self, x, js):
        return self.a_y


class EnsembleSimulator:
    """Simulate realisations of the single-track model with a structure's effects.

    Parameters
    ----------
    settings : Settings
        The car's constants, the wind and its KLE settings.
    time : ndarray, shape (T,)
        Uniform output grid from 0 (s).
    delta : ndarray, shape (T,)
        Commanded steering angle (rad).
    v_c : float
        Speed (m/s).
    stride : int
        States are returned every ``stride`` grid steps (``output_time``); the inputs still act
        on the whole grid (the first-order-hold maps of the skipped steps are folded, exactly),
        so a coarser output costs a fraction of the recursion. The grid is cut to a multiple.
    interpolation : {"linear", "previous"}
        How ``delta`` is reconstructed between its samples (the data file's ``delta`` attribute
        ``interpolation``): piecewise linear, or each sample held (zero-order hold).
    channels : sequence of str
        Measured channels returned, in order: of psi, psi_dot, beta, y, a_y (:mod:`uqdrive.vehicle.track_rk4`).
    speed : ndarray, shape (T,), optional
        Speed v(t) (m/s) on ``time`` when it changes (time-varying model, by RK4); None: ``v_c``.
    kle : KarhunenLoeve, optional
        The wind's KLE over the grid's horizon, if already computed (else from the settings).
    linear_profile : {"rk4", "exact"}
        How the linear model (the thesis' LST, no effects) is integrated along ``speed``: by RK4
        (:class:`~uqdrive.vehicle.track_rk4.LinearTrackRHS`), or discretised exactly per grid
        step at the step's mean speed and slope (:func:`~uqdrive.vehicle.dynamics.ensemble.simulate_lst_ltv`,
        the PCE channel model's splitting and the Monte Carlo data sets').
    drive : HalfStepDrive, optional
        Steering, gust modes (and speed) evaluated by the caller at every half step of the
        grid's step: non-linear structures and ``drive.speed`` are integrated by RK4 on them
        (no steering lag or delay: the caller's angle is the actual one).
    backend : {"numpy", "jax"}
        Who integrates the non-linear structures on the grid (:func:`uqdrive.numerics.backend.resolve_device`):
        the NumPy and compiled CPU path, or JAX on its default device
        (:func:`uqdrive.vehicle.accelerated.chassis_ensemble.integrate_chassis_jax`, the same numbers to 1e-10);
        the exact discretisations and a half-step drive stay on the CPU.

    Attributes
    ----------
    output_time : ndarray, shape (K + 1,)
        Times (s) of the returned states.
    """

    def __init__(self, settings: Settings, time, delta, v_c: float, stride: int = 1, interpolation: str = "linear", channels=STATES,
                 speed=None, kle: KarhunenLoeve | None = None, linear_profile: str = "rk4", drive: HalfStepDrive | None = None,
                 backend: str = "numpy"):
        if backend not in ("numpy", "jax"):
            raise ValueError(f"backend is 'numpy' or 'jax', not {backend!r}")
        self.backend = backend
        time = np.asarray(time, float)
        self.channels = tuple(channels)
        self.spin_row = self.channels.index("beta") if "beta" in self.channels else None
        self.interpolation = checked_interpolation(interpolation)
        self.stride = max(1, int(stride))
        horizon = float(time[-1])  # the wind's KLE lives on the data's whole horizon
        usable = 1 + ((time.size - 1) // self.stride) * self.stride
        self.time = time[:usable]
        delta = np.asarray(delta, float)[:usable]
        self.output_time = self.time[:: self.stride]
        self.dt = float(self.time[1] - self.time[0])
        self.delta = delta
        self.car = settings.vehicle
        w = settings.wind
        self.kle = kle_of_wind(w, horizon) if kle is None else kle
        # (n_c, T); a drive holds them at the grid's times already (its even half steps)
        self.f = self.kle.eigenfunctions(self.time) if drive is None else drive.eigenfunctions[:, : 2 * usable - 1: 2]
        self.sigma = float(w.sigma)
        self.gust_yaw_moment = bool(w.gust_yaw_moment)
        self.base = replace(VehicleParameters.from_settings(settings), v_c=float(v_c))
        self.speed = None if speed is None else np.asarray(speed, float)[:usable]
        self.drive = drive
        if linear_profile not in ("rk4", "exact"):
            raise ValueError(f"linear_profile is 'rk4' or 'exact', not {linear_profile!r}")
        self.linear_profile = linear_profile
        if drive is not None and drive.speed is not None and self.speed is None:
            self.speed = drive.speed[0][: 2 * usable - 1: 2]  # on the grid: for the speed's checks, the half steps' values drive
        self._gust_products: dict = {}  # shared by the copies (with_input, and the germs' copies of a subclass): see _gusts
        self._wind_table = threading.local()  # the (J, n) wind of the last RK4 pass, its memory reused: see _wind_half
        self._reference_loads = (float(self.base.F_fz), float(self.base.F_rz))  # the nominal car's: the tyre constants' loads

    @classmethod
    def driven(cls, settings: Settings, grid: TimeGrid, delta_half, eigenfunctions_half, v_c: float, speed_half=None,
               kle: KarhunenLoeve | None = None) -> "EnsembleSimulator":
        """The simulator of the Monte Carlo data sets: RK4 at ``grid.step`` on inputs evaluated at
        its half steps (:class:`HalfStepDrive`), states every ``grid.substeps`` steps, the gusts
        formed per half step; along a speed profile the rate is the central difference of the
        half-step speeds (``np.gradient``) and the balances divide (``quotient``).

        Parameters
        ----------
        settings : Settings
        grid : TimeGrid
            The output grid and the RK4 step.
        delta_half : ndarray, shape (J,)
            Front wheel angle (rad) on ``grid.fine(2)``.
        eigenfunctions_half : ndarray, shape (n_c, J)
            KLE eigenfunctions (-) on ``grid.fine(2)``.
        v_c : float
            Speed (m/s) at constant speed.
        speed_half : ndarray, shape (J,), optional
            Speed v (m/s) on ``grid.fine(2)``; None: ``v_c``.
        kle : KarhunenLoeve, optional
            The wind's KLE, if already computed.
        """
        speed = None
        if speed_half is not None:
            speed_half = np.asarray(speed_half, float)
            speed = (speed_half, np.gradient(speed_half, grid.step / 2.0))
        drive = HalfStepDrive(grid.step, np.asarray(delta_half, float), np.asarray(eigenfunctions_half, float), speed, quotient=speed is not None)
        t_half = grid.fine(2)
        return cls(settings, t_half[::2], drive.steering[::2], v_c, stride=grid.substeps, kle=kle, drive=drive)

    def with_input(self, delta) -> "EnsembleSimulator":
        """The same model (and realisations) steered by another command ``delta`` (rad) on the same grid
        (shape (T,) of the grid given at construction, or already cut to ``time``)."""
        other = object.__new__(type(self))
        other.__dict__.update(self.__dict__)
        delta = np.asarray(delta, float)
        if delta.size < self.time.size:
            raise ValueError(f"the input has {delta.size} samples; the grid needs {self.time.size}")
        other.delta = delta[: self.time.size]
        return other

    def realise(self, p: VehicleParameters, wind, coeffs, structure: ModelStructure = ModelStructure()) -> np.ndarray:
        """Channels as measured, shape (C, n, K + 1) at ``output_time``, of n realisations given by
        their parameters ``p`` (arrays (n,)), mean wind ``wind`` (n,) (N) and gust mode coefficients
        ``coeffs`` (n, n_c) (N), with the effects of ``structure``."""
        p = with_tyre_shape(p, structure)
        coeffs = coeffs * structure.gust_scale
        if self.drive is not None:
            if structure.steering_lag or structure.steering_delay:
                raise ValueError("a half-step drive's steering is the actual angle: no steering lag or delay")
            delta = self.delta
        else:
            delta = actual_steering(self.delta, self.dt, structure.steering_lag, structure.steering_delay, self.interpolation)
        if self.speed is not None and self.linear_profile == "exact" and not structure.nonlinear:
            if structure != ModelStructure() or self.channels != STATES:
                raise ValueError("the exact discretisation along a speed profile is the thesis' LST's: no effects, the four states")
            return simulate_lst_ltv(p, delta, wind, coeffs, self.f, self.dt, self.stride, self.speed, self.gust_yaw_moment)
        if self.speed is not None or self.channels != STATES:
            return self._channels(p, wind, coeffs, delta, structure)
        if structure.nonlinear:
            x = self._rk4(p, wind, coeffs, delta, structure)
        else:
            x = self._exact(p, wind, coeffs, delta, structure)
        if all(g == 1.0 for g in structure.output_gain) and not any(structure.output_offset):  # as measured = as simulated: no copy of x
            return x
        return measured_channels(x, None, structure, STATES)

    def _substeps(self, s: ModelStructure) -> int:
        """RK4 steps per sample of the grid: the step at most ``RK4_MAX_STEP``, and short enough
        for the fastest slip lag and the roll mode of the chassis terms."""
        v_max = self.base.v_c if self.speed is None else max(float(self.base.v_c), float(np.max(self.speed)))
        return max(1, int(np.ceil(self.dt / s.max_step(v_max, RK4_MAX_STEP) - 1e-9)))

    def _channels(self, p, wind, coeffs, delta, s: ModelStructure):
        """The measured channels (C, n, K + 1) with the structure's output map: the states of the
        exact, RK4 or (along a speed profile) time-varying model, a_y from the same model."""
        a_y = None
        if self.speed is not None or s.nonlinear:
            x, rhs, js = self._rk4(p, wind, coeffs, delta, s, with_rhs=True)
            a_y = rk4_lateral_acceleration(rhs, x, js) if "a_y" in self.channels else None
        else:
            x = self._exact(p, wind, coeffs, delta, s)
            if "a_y" in self.channels:
                F_w = wind[:, None] + coeffs @ self.f[:, :: self.stride]
                a_y = linear_lateral_acceleration(p, x, delta[:: self.stride], F_w, p.v_c, s.compliance_steer)
        return measured_channels(x, a_y, s, self.channels)

    def _eigenfunctions(self, t_half):  # the KLE eigenfunctions (n_c, J), kept for the next call on the same grid
        key = (t_half.size, float(t_half[-1]))
        if getattr(self, "_f_half", (None,))[0] != key:
            self._f_half = (key, self.kle.eigenfunctions(t_half))
        return self._f_half[1]

    def _gusts(self, coeffs, f_half, t_half):
        """Gust forces (J, n) of the realisations' mode coefficients ``coeffs`` (n, n_c) on the
        half steps: the product ``f_half.T @ coeffs.T``, which BLAS writes in that layout (the
        transpose of ``coeffs @ f_half`` to rounding, its bits on some CPUs' kernels; computing
        that and copying its transpose cost six times as much at 4000 realisations); a part of
        the realisations gets the columns of the whole table, bit for bit, up to seven modes. It depends on the germs and the
        gust scale, not on theta, so a fit's simulations share it: the most recent
        :data:`GUST_PRODUCTS` are kept (with the copies of this simulator on other germs or
        inputs), each computed as the first call did, so the numbers are those of a fresh product."""
        key = (t_half.size, float(t_half[-1]), coeffs.shape, coeffs.tobytes())
        cache = self._gust_products
        product = cache.pop(key, None)
        if product is None:
            product = f_half.T @ coeffs.T
        if product.nbytes > GUST_BYTES:  # a bootstrap's fresh germs: never asked for again
            return product
        cache[key] = product
        while len(cache) > GUST_PRODUCTS:
            cache.pop(next(iter(cache)))
        return product

    def _wind_half(self, J: int, n: int):
        """An uninitialised (J, n) array for a pass's wind per half step, the memory of the previous
        pass's (this thread's, shared by the copies). A fresh array of a pass's size (tens of MB)
        costs three times the sums written into it (the kernel zeroes its pages on first touch);
        the table lives only through its pass, whose right-hand side (and a_y from it) is used
        before the next pass starts."""
        held = getattr(self._wind_table, "memory", None)
        if held is None or held.size < J * n:
            held = self._wind_table.memory = np.empty(J * n)
        return held[: J * n].reshape(J, n)

    def _held_input(self, s: ModelStructure) -> bool:
        """The actual steering is the held command itself (delayed): piecewise constant."""
        return self.interpolation == "previous" and s.steering_lag <= 0

    def _exact(self, p, wind, coeffs, delta, s: ModelStructure):
        A, B, W = lst_matrices(with_compliance_steer(p, s.compliance_steer))  # the compliance: a softer front axle
        A = A.copy()
        A[:, 3, 2] = s.course_weight * p.v_c  # y_dot = v (psi + k beta), its linear part
        held = self._held_input(s)
        steer = None
        if held:
            # x' = A x + B u with u held: z = x - B w, w = int u dt (piecewise linear) obeys
            # z' = A z + (A B) w, which the first-order hold integrates exactly
            steer = np.einsum("nij,nj->ni", A, B)
            delta = held_integral(self.delta, self.dt, s.steering_delay)
        x = exact_response((A, B, W), delta, wind, coeffs, self.f, self.dt, self.stride, self.gust_yaw_moment,
                           s.lateral_acceleration / p.v_c, steer)
        if held:
            x += B.T[:, :, None] * delta[:: self.stride][None, None, :]
        if s.course_exact:
            x[3] += p.v_c * cumulative_trapezoid(np.sin(x[0] + s.course_weight * x[2]) - (x[0] + s.course_weight * x[2]), self.dt * self.stride)
        return x

    def _delta_half(self, delta, s: ModelStructure, t_half):
        """The actual steering angle (J,) (rad) at the half-step times ``t_half`` (J,), from the
        actual angle ``delta`` (T,) on the grid (the held command itself where :meth:`_held_input`)."""
        if self._held_input(s):
            # the held value at each half step; where it jumps (a step's end, shared with the next
            # step's start) the mean of both sides: the last stage of the step before and the first
            # of the step after then err by opposite amounts, and the jump arrives in time
            value = lambda i: np.where(i >= 0, self.delta[np.clip(i, 0, self.delta.size - 1)], 0.0)  # noqa: E731
            t_shift = t_half - s.steering_delay
            return 0.5 * (value(held_index(t_half, self.dt, s.steering_delay)) + value(np.ceil(t_shift / self.dt - 1e-9).astype(int) - 1))
        return np.interp(t_half, self.time, delta)

    def _rk4(self, p, wind, coeffs, delta, s: ModelStructure, groups=None, with_rhs: bool = False):
        """RK4 states (4, n, K + 1), a time-major view (as :func:`~uqdrive.vehicle.dynamics.ensemble.exact_response`'s).

        ``delta``: the actual steering (T,) of all realisations, or a list of (actual steering,
        structure) of each of equal consecutive parts of the realisations (``per_pair_input``).
        ``groups``: sizes (realisations) of consecutive parts whose gusts are computed as one
        product each (default: one part). BLAS rounds a product differently for other widths,
        so a realisation's last bits depend on the product it was computed in (and on nothing
        else: the RK4 is element-wise); see :meth:`simulate_many`. ``with_rhs``: also the
        right-hand side and the half-step index of every returned time (for a_y); along a
        speed profile a linear structure is integrated here too (:class:`LinearTrackRHS`).
        """
        if self.drive is not None:
            return self._driven(p, wind, coeffs, s, with_rhs)
        sub = self._substeps(s)
        h = self.dt / sub
        n_steps = (self.time.size - 1) * sub
        t_half = np.arange(2 * n_steps + 1) * (h / 2)
        if isinstance(delta, list):  # (actual steering, structure) of each part of n realisations: the angle per realisation
            n = wind.size // len(delta)
            delta_half = np.empty((t_half.size, wind.size))
            for i, (delta_i, s_i) in enumerate(delta):
                delta_half[:, i * n:(i + 1) * n] = self._delta_half(delta_i, s_i, t_half)[:, None]
        else:
            delta_half = self._delta_half(delta, s, t_half)
        f_half = self._eigenfunctions(t_half)  # (n_c, n_half)
        E = self.car.E if s.tyre_curvature is None else s.tyre_curvature
        js = np.arange(self.output_time.size) * (2 * sub * self.stride)
        speed = None if self.speed is None else speed_on_half_steps(self.time, self.speed, t_half)
        if self.backend == "jax" and (s.uses_chassis or s.nonlinear):  # the gusts and a_y formed on the device
            from ..accelerated.chassis_ensemble import integrate_chassis_jax

            rhs = chassis_rhs(self.car, p, s, E, delta_half, None, self.gust_yaw_moment, wind, speed, self._reference_loads)
            x, a_y = integrate_chassis_jax(rhs, h, n_steps, sub * self.stride, wind, coeffs, f_half, with_rhs and "a_y" in self.channels)
            return (x.transpose(1, 2, 0), _Recorded(a_y), js) if with_rhs else x.transpose(1, 2, 0)
        # wind force per half step with one contiguous row of realisations each, (n_half, n)
        F_w_half = self._wind_half(t_half.size, wind.size)
        start = 0
        for size in (groups or [wind.size]):
            np.add(self._gusts(coeffs[start:start + size], f_half, t_half), wind[start:start + size], F_w_half[:, start:start + size])
            start += size
        if with_rhs:
            if s.uses_chassis and s.nonlinear:  # every state (the lagged slip angles: a_y needs them)
                return (*integrate_chassis(self.car, p, s, E, delta_half, F_w_half, self.gust_yaw_moment, wind, h, n_steps, sub * self.stride, True,
                                           speed, self._reference_loads), js)
            heading = bool({"psi", "y"} & set(self.channels))  # else psi_dot and beta alone: the same numbers
            if not s.nonlinear:
                rhs = LinearTrackRHS(p, s, delta_half, F_w_half, self.gust_yaw_moment, wind, *speed, heading=heading)
                return integrate_linear_ltv(rhs, h, n_steps, sub * self.stride), rhs, js
            rhs = SingleTrackRHS.of_structure(p, s, E, delta_half, F_w_half, self.gust_yaw_moment, wind, speed, heading)
            return integrate_single_track(rhs, h, n_steps, sub * self.stride).transpose(1, 2, 0), rhs, js
        if s.uses_chassis:
            return integrate_chassis(self.car, p, s, E, delta_half, F_w_half, self.gust_yaw_moment, wind, h, n_steps, sub * self.stride,
                                     reference_loads=self._reference_loads)
        rhs = SingleTrackRHS.of_structure(p, s, E, delta_half, F_w_half, self.gust_yaw_moment, wind)
        out = integrate_single_track(rhs, h, n_steps, sub * self.stride)  # (K + 1, 4, n)
        return out.transpose(1, 2, 0)  # no copy: the statistics take their times from it

    def _driven(self, p, wind, coeffs, s: ModelStructure, with_rhs: bool):
        """:meth:`_rk4` on the :class:`HalfStepDrive`'s inputs at its step (states, and with
        ``with_rhs`` the right-hand side and the half-step index of every returned time)."""
        d = self.drive
        n_steps = self.time.size - 1
        E = self.car.E if s.tyre_curvature is None else s.tyre_curvature
        heading = not with_rhs or bool({"psi", "y"} & set(self.channels))
        M_w = None if self.gust_yaw_moment else p.M_c * np.asarray(wind, float)
        if d.gusts_per_step:
            inputs = GustInputs(d.steering, wind, coeffs, d.eigenfunctions, M_w)
        else:
            inputs = HalfStepInputs(d.steering, np.ascontiguousarray((coeffs @ d.eigenfunctions).T) + wind, M_w)
        if s.uses_chassis or not s.nonlinear and d.speed is not None:
            raise ValueError("a half-step drive integrates the single-track right-hand side: no chassis terms, no linear model along a speed profile")
        rhs = SingleTrackRHS(p, inputs, tyre=s.tyre, E=E, course_weight=s.course_weight, lateral_acceleration=s.lateral_acceleration,
                             speed_half=d.speed, heading=heading, quotient=d.quotient)
        x = integrate_single_track(rhs, d.step, n_steps, self.stride).transpose(1, 2, 0)
        return (x, rhs, np.arange(self.output_time.size) * (2 * self.stride)) if with_rhs else x

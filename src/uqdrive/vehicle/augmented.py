"""Ensembles of the single-track model with named effects added (a :class:`ModelStructure`), on
any measured time grid and steering signal, from fixed germs (common random numbers).

Linear structures are discretised exactly (first-order hold, as the LST ensembles); a non-linear
tyre is integrated by vectorised RK4. With the germs fixed, the moments are smooth functions of
the distribution and effect parameters, so optimisers can fit them (past the thesis).
"""

from __future__ import annotations

from dataclasses import replace
import numpy as np

from ..numerics.integrate import cumulative_trapezoid
from ..settings import ParameterLayout, Settings
from .effects import ModelStructure, shape_parts, with_tyre_shape
from .effects.terms import CHASSIS_FIELDS
from .single_track import STATES, VehicleParameters, lst_matrices, with_compliance_steer
from .track_extended import integrate_chassis
from .dynamics.ensemble import exact_response
from .dynamics.rhs import SingleTrackRHS
from .track_rk4 import (LinearTrackRHS, integrate_linear_ltv, integrate_single_track, linear_lateral_acceleration, measured_channels,
                        rk4_lateral_acceleration, speed_on_half_steps)
from ..numerics.sampled_input import INTERPOLATIONS, checked_interpolation, actual_steering, held_index, held_integral, reconstruction_error
from .uncertainty import Germs, kle_of_wind, uniform_from_germ

__all__ = ["THETA_NAMES", "INTERPOLATIONS", "Germs", "actual_steering", "held_index", "held_integral", "reconstruction_error", "AugmentedSimulator"]

#: Distribution parameters identified with every structure: mu ~ N, l_f ~ N, mean wind ~ U.
THETA_NAMES = ParameterLayout.names
_RK4_MAX_STEP = 0.01  # s: stable (|h lambda| < 0.5) and within 1e-4 of the 5 ms reference
#: Realisations of one RK4 pass of linear models along a speed profile: past a few thousand a
#: step's NumPy calls cost their arithmetic, and the half-step wind forces (2 steps x realisations) grow.
_PASS_REALISATIONS = 8000
#: Gust products kept per simulator (:meth:`AugmentedSimulator._gusts`; 16 MB each at 1000
#: realisations and 2000 half steps).
_GUST_PRODUCTS, _GUST_BYTES = 4, 40_000_000


class AugmentedSimulator:
    """Simulate an augmented single-track model for distribution parameters ``theta``.

    Parameters
    ----------
    settings : Settings
        The car's constants, the load distribution (fixed, not identified: the LST depends on
        the mass only through F_w / m), the wind and its KLE settings.
    time : ndarray, shape (T,)
        Uniform output grid from 0 (s).
    delta : ndarray, shape (T,)
        Commanded steering angle (rad).
    v_c : float
        Speed (m/s).
    germs : Germs
        Fixed germs of the realisations (common random numbers).
    stride : int
        States are returned every ``stride`` grid steps (``output_time``); the inputs still act
        on the whole grid (the first-order-hold maps of the skipped steps are folded, exactly),
        so a coarser output costs a fraction of the recursion. The grid is cut to a multiple.
    interpolation : {"linear", "previous"}
        How ``delta`` is reconstructed between its samples (the data file's ``delta`` attribute
        ``interpolation``): piecewise linear, or each sample held (zero-order hold).
    channels : sequence of str
        Measured channels returned, in order: of psi, psi_dot, beta, y, a_y (:mod:`.track_rk4`).
    speed : ndarray, shape (T,), optional
        Speed v(t) (m/s) on ``time`` when it changes (time-varying model, by RK4); None: ``v_c``.

    Attributes
    ----------
    output_time : ndarray, shape (K + 1,)
        Times (s) of the returned states.
    """

    def __init__(self, settings: Settings, time, delta, v_c: float, germs: Germs, stride: int = 1, interpolation: str = "linear",
                 channels=STATES, speed=None):
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
        self.germs = germs
        self.car = settings.vehicle
        self.load = settings.uncertainty.m_load
        w = settings.wind
        self.kle = kle_of_wind(w, horizon)
        if germs.kle.shape[1] < self.kle.n_modes:
            raise ValueError(f"germs hold {germs.kle.shape[1]} KLE modes; the wind needs {self.kle.n_modes}")
        self.f = self.kle.eigenfunctions(self.time)  # (n_c, T)
        self.sigma = float(w.sigma)
        self.gust_yaw_moment = bool(w.gust_yaw_moment)
        self.m_load = self.load.mean + self.load.std * germs.m_load
        self.base = replace(VehicleParameters.from_settings(settings), v_c=float(v_c))
        self.speed = None if speed is None else np.asarray(speed, float)[:usable]
        self._gust_products: dict = {}  # shared by the copies (with_germs, with_input): see _gusts
        self._reference_loads = (float(self.base.F_fz), float(self.base.F_rz))  # the nominal car's: the tyre constants' loads

    @classmethod
    def drawn(cls, settings: Settings, time, delta, v_c: float, n: int, rng: np.random.Generator, stride: int = 1,
              matched: bool = False, interpolation: str = "linear", channels=STATES, speed=None) -> "AugmentedSimulator":
        """A simulator on ``n`` germs drawn from ``rng`` (as many KLE modes as the horizon needs),
        moment-matched if ``matched`` (:meth:`Germs.matched`: for model ensembles, not for data)."""
        n_modes = kle_of_wind(settings.wind, float(np.asarray(time)[-1])).n_modes
        return cls(settings, time, delta, v_c, Germs.draw(rng, n, n_modes, matched), stride, interpolation, channels, speed)

    def with_germs(self, germs: Germs) -> "AugmentedSimulator":
        """The same model on other germs (the KLE is reused)."""
        other = object.__new__(AugmentedSimulator)
        other.__dict__.update(self.__dict__)
        other.germs = germs
        other.m_load = self.load.mean + self.load.std * germs.m_load
        return other

    def with_input(self, delta) -> "AugmentedSimulator":
        """The same model and germs steered by another command ``delta`` (rad) on the same grid
        (shape (T,) of the grid given at construction, or already cut to ``time``)."""
        other = object.__new__(AugmentedSimulator)
        other.__dict__.update(self.__dict__)
        delta = np.asarray(delta, float)
        if delta.size < self.time.size:
            raise ValueError(f"the input has {delta.size} samples; the grid needs {self.time.size}")
        other.delta = delta[: self.time.size]
        return other

    def parameters(self, theta, germs: Germs | None = None) -> tuple[VehicleParameters, np.ndarray, np.ndarray]:
        """Per-realisation vehicle parameters, mean wind (N) and gust mode coefficients (N).

        Draws outside the physical range (mu <= 0, l_f outside (0, L)) from the normals' tails
        are clipped to it, as a real car has mu > 0 and its centre of gravity between the axles.
        """
        mu_m, mu_s, lf_m, lf_s, lo, hi = np.asarray(theta, float)
        g = self.germs if germs is None else germs
        L = self.base.wheelbase
        m_load = self.m_load if germs is None else self.load.mean + self.load.std * g.m_load
        mu = np.maximum(mu_m + mu_s * g.mu, 0.05)
        l_f = np.clip(lf_m + lf_s * g.l_f, 0.05 * L, 0.95 * L)
        p = replace(self.base, mu=mu, l_f=l_f, m_load=np.maximum(m_load, -0.9 * self.base.m_base))
        wind = uniform_from_germ(g.wind, lo, hi)
        coeffs = self.sigma * g.kle[:, : self.kle.n_modes] * np.sqrt(self.kle.eigenvalues)
        return p, wind, coeffs

    def simulate(self, theta, structure: ModelStructure = ModelStructure(), germs: Germs | None = None) -> np.ndarray:
        """Channels as measured, shape (C, n, K + 1) at ``output_time``: the ``channels`` (by
        default psi, psi_dot, beta, y) of every realisation (of ``germs`` if given, else of the
        simulator's own)."""
        p, wind, coeffs = self.parameters(theta, germs)
        p = with_tyre_shape(p, structure)
        coeffs = coeffs * structure.gust_scale
        delta = actual_steering(self.delta, self.dt, structure.steering_lag, structure.steering_delay, self.interpolation)
        if self.speed is not None or self.channels != STATES:
            return self._channels(p, wind, coeffs, delta, structure)
        if structure.nonlinear:
            x = self._rk4(p, wind, coeffs, delta, structure)
        else:
            x = self._exact(p, wind, coeffs, delta, structure)
        gain = np.asarray(structure.output_gain, float)[:, None, None]
        offset = np.asarray(structure.output_offset, float)[:, None, None]
        if np.all(gain == 1.0) and not np.any(offset):  # as measured = as simulated: no copy of x
            return x
        return x * gain + offset

    def simulate_many(self, thetas, structures, groups=None) -> list:
        """:meth:`simulate` for several (theta, structure) pairs, as one batch where the model
        is integrated numerically (one RK4 pass over all realisations of all pairs: a step's
        NumPy call overhead is paid once; at 300 realisations it is half the cost of a pass);
        pairs of different tyre shapes (b, C) in passes of one shape each.

        ``groups``: numbers of consecutive pairs (summing to their count) that are computed as
        if each group were a call of its own: the pairs of a group get the same numbers, to the
        last bit, as ``simulate_many`` of that group alone (one pair: as :meth:`simulate`).
        Default: one group.
        """
        thetas, n = [np.asarray(th, float) for th in thetas], self.germs.n
        if len({s.tyre_shape() for s in structures}) > 1:
            return self._shapes_many(thetas, structures, groups)
        if self.speed is not None and len(thetas) > 1 and not any(s.nonlinear for s in structures):
            return self._profile_many(thetas, structures)
        first = structures[0]
        same_input = all((s.steering_lag, s.steering_delay) == (first.steering_lag, first.steering_delay) for s in structures)
        if not all(s.nonlinear for s in structures) or len(thetas) == 1:
            return [self.simulate(th, s) for th, s in zip(thetas, structures)]
        if any(s.uses_chassis for s in structures):  # a pass per steering input (a fitted lag's or delay's neighbours) and chassis kind
            return self._in_passes(thetas, structures, lambda s: None if self._chassis_kind(s) is None else
                                   (s.steering_lag, s.steering_delay, self._chassis_kind(s)), chassis=True)
        if not same_input:  # a fitted lag's or delay's neighbours: a pass per tyre, kinematics and step, each pair steered by its own angle
            return self._in_passes(thetas, structures, lambda s: (s.tyre, bool(s.course_exact), self._substeps(s)), max(1, _PASS_REALISATIONS // n),
                                   per_pair_input=True)
        return self._one_pass(thetas, structures, None if groups is None else [g * n for g in groups])

    def _shapes_many(self, thetas, structures, groups) -> list:
        """:meth:`simulate_many` of pairs of different tyre shapes (a pass shares one B and C): each group's pairs of one shape in one call."""
        out = [None] * len(thetas)
        for m in shape_parts(structures, groups):
            for i, x in zip(m, self.simulate_many([thetas[i] for i in m], [structures[i] for i in m])):
                out[i] = x
        return out

    def _in_passes(self, thetas, structures, kind, per_pass: int | None = None, **options) -> list:
        """:meth:`simulate_many` of the pairs whose ``kind(structure)`` is equal (None: a pair of
        its own) as RK4 passes of at most ``per_pass`` pairs (default: all), each pair's gusts
        its own product, so that every pair gets the numbers of :meth:`simulate`, bit for bit
        (the right-hand sides are element-wise in the realisations and the steering angle);
        ``options`` go to :meth:`_one_pass`. One pass instead of a call per pair: at a few
        hundred realisations a step's NumPy calls cost more than their arithmetic."""
        out = [None] * len(thetas)
        kinds: dict = {}
        for i, s in enumerate(structures):
            kinds.setdefault(kind(s), []).append(i)
        for key, members in kinds.items():
            size = 1 if key is None else (per_pass or len(members))
            for start in range(0, len(members), size):
                part = members[start:start + size]
                if len(part) == 1:
                    out[part[0]] = self.simulate(thetas[part[0]], structures[part[0]])
                    continue
                sims = self._one_pass([thetas[i] for i in part], [structures[i] for i in part], [self.germs.n] * len(part), **options)
                for i, x_i in zip(part, sims):
                    out[i] = x_i
        return out

    def _profile_many(self, thetas, structures) -> list:
        """Linear pairs along a speed profile (RK4, :class:`LinearTrackRHS`): a pass per steering input, kinematics and lateral acceleration."""
        kind = lambda s: (s.steering_lag, s.steering_delay, bool(s.course_exact), bool(np.any(np.asarray(s.lateral_acceleration) != 0)))  # noqa: E731
        return self._in_passes(thetas, structures, kind, max(1, _PASS_REALISATIONS // self.germs.n), chassis=True)

    def _one_pass(self, thetas, structures, groups, chassis: bool = False, per_pair_input: bool = False) -> list:
        """The pairs' channels from one RK4 pass over all their realisations (``groups``: sizes
        in realisations of the parts whose gusts are one product each, :meth:`_rk4`;
        ``per_pair_input``: each pair steered by its own lag and delay, else by the first's)."""
        n = self.germs.n
        p, wind, coeffs, batch = self._batch(thetas, structures, chassis)
        if per_pair_input:
            delta = [(actual_steering(self.delta, self.dt, s.steering_lag, s.steering_delay, self.interpolation), s) for s in structures]
        else:
            delta = actual_steering(self.delta, self.dt, batch.steering_lag, batch.steering_delay, self.interpolation)
        if self.speed is not None or self.channels != STATES:
            x, rhs, js = self._rk4(p, wind, coeffs, delta, batch, groups=groups, with_rhs=True)
            a_y = rk4_lateral_acceleration(rhs, x, js) if "a_y" in self.channels else None
            return [measured_channels(x[:, i * n:(i + 1) * n], None if a_y is None else a_y[i * n:(i + 1) * n], s, self.channels)
                    for i, s in enumerate(structures)]
        x = self._rk4(p, wind, coeffs, delta, batch, groups=groups)
        return [x[:, i * n:(i + 1) * n] * np.asarray(s.output_gain, float)[:, None, None] + np.asarray(s.output_offset, float)[:, None, None]
                for i, s in enumerate(structures)]

    def _batch(self, thetas, structures, chassis: bool = False):
        """Parameters, mean wind, gust coefficients and one structure (its per-pair fields as
        arrays of n per pair) of the pairs' realisations side by side."""
        n = self.germs.n
        parts = [self.parameters(th) for th in thetas]
        p = replace(parts[0][0], mu=np.concatenate([q[0].mu for q in parts]), l_f=np.concatenate([q[0].l_f for q in parts]),
                    m_load=np.concatenate([np.broadcast_to(q[0].m_load, (n,)) for q in parts]))
        wind = np.concatenate([q[1] for q in parts])
        coeffs = np.concatenate([q[2] * s.gust_scale for q, s in zip(parts, structures)])
        per = lambda attr, default: np.repeat([default if getattr(s, attr) is None else getattr(s, attr) for s in structures], n)  # noqa: E731
        fields = {"tyre_curvature": self.car.E, "lateral_acceleration": 0.0, "course_weight": 0.0}
        if chassis:
            fields.update({f: 0.0 for f in CHASSIS_FIELDS})
        return with_tyre_shape(p, structures[0]), wind, coeffs, replace(structures[0], **{f: per(f, d) for f, d in fields.items()})

    def _chassis_kind(self, s: ModelStructure):
        """What must be equal for pairs to share an RK4 pass of the chassis right-hand side: the
        tyre, the kinematics, which terms are on, the step; None: not a chassis structure."""
        if not s.uses_chassis:
            return None
        return (s.tyre, bool(s.course_exact), s.chassis_switches(), self._substeps(s))

    def _substeps(self, s: ModelStructure) -> int:
        """RK4 steps per sample of the grid: the step at most ``_RK4_MAX_STEP``, and short enough
        for the fastest slip lag and the roll mode of the chassis terms."""
        v_max = self.base.v_c if self.speed is None else max(float(self.base.v_c), float(np.max(self.speed)))
        return max(1, int(np.ceil(self.dt / s.max_step(v_max, _RK4_MAX_STEP) - 1e-9)))

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
        half steps: the product ``coeffs @ f_half``, transposed. It depends on the germs and the
        gust scale, not on theta, so a fit's simulations share it: the most recent
        :data:`_GUST_PRODUCTS` are kept (with the copies of this simulator on other germs or
        inputs), each computed as the first call did, so the numbers are those of a fresh product."""
        key = (t_half.size, float(t_half[-1]), coeffs.shape, coeffs.tobytes())
        cache = self._gust_products
        product = cache.pop(key, None)
        if product is None:
            product = np.ascontiguousarray((coeffs @ f_half).T)
        if product.nbytes > _GUST_BYTES:  # a bootstrap's fresh germs: never asked for again
            return product
        cache[key] = product
        while len(cache) > _GUST_PRODUCTS:
            cache.pop(next(iter(cache)))
        return product

    def _held_input(self, s: ModelStructure) -> bool:
        """The actual steering is the held command itself (delayed): piecewise constant."""
        return self.interpolation == "previous" and s.steering_lag <= 0

    def _exact(self, p, wind, coeffs, delta, s: ModelStructure):
        A, B, W = lst_matrices(with_compliance_steer(p, s.compliance_steer))  # the compliance: a softer front axle
        A = A.copy()
        A[:, 3, 2] = s.course_weight * p.v_c  # y_dot = v (psi + k beta), its linear part
        bank = np.zeros((A.shape[0], 4))
        bank[:, 2] = s.lateral_acceleration / p.v_c
        held = self._held_input(s)
        steer = None
        if held:
            # x' = A x + B u with u held: z = x - B w, w = int u dt (piecewise linear) obeys
            # z' = A z + (A B) w, which the first-order hold integrates exactly
            steer = np.einsum("nij,nj->ni", A, B)
            delta = held_integral(self.delta, self.dt, s.steering_delay)
        x = exact_response((A, B, W), delta, wind, coeffs, self.f, self.dt, self.stride, self.gust_yaw_moment, bank, steer)
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
        structure) of each consecutive part of ``germs.n`` realisations (``per_pair_input``).
        ``groups``: sizes (realisations) of consecutive parts whose gusts are computed as one
        product each (default: one part). BLAS rounds a product differently for other widths,
        so a realisation's last bits depend on the product it was computed in (and on nothing
        else: the RK4 is element-wise); see :meth:`simulate_many`. ``with_rhs``: also the
        right-hand side and the half-step index of every returned time (for a_y); along a
        speed profile a linear structure is integrated here too (:class:`LinearTrackRHS`).
        """
        sub = self._substeps(s)
        h = self.dt / sub
        n_steps = (self.time.size - 1) * sub
        t_half = np.arange(2 * n_steps + 1) * (h / 2)
        if isinstance(delta, list):  # (actual steering, structure) of each part of n realisations: the angle per realisation
            n = self.germs.n
            delta_half = np.empty((t_half.size, wind.size))
            for i, (delta_i, s_i) in enumerate(delta):
                delta_half[:, i * n:(i + 1) * n] = self._delta_half(delta_i, s_i, t_half)[:, None]
        else:
            delta_half = self._delta_half(delta, s, t_half)
        f_half = self._eigenfunctions(t_half)  # (n_c, n_half)
        # wind force per half step with one contiguous row of realisations each, (n_half, n)
        F_w_half = np.empty((t_half.size, wind.size))
        start = 0
        for size in (groups or [wind.size]):
            np.add(self._gusts(coeffs[start:start + size], f_half, t_half), wind[start:start + size], F_w_half[:, start:start + size])
            start += size
        E = self.car.E if s.tyre_curvature is None else s.tyre_curvature
        if with_rhs:
            js = np.arange(self.output_time.size) * (2 * sub * self.stride)
            speed = None if self.speed is None else speed_on_half_steps(self.time, self.speed, t_half)
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

"""Ensembles of the single-track model with named effects added (a :class:`ModelStructure`), on
any measured time grid and steering signal, from fixed germs (common random numbers).

The realisations are simulated by :class:`uqdrive.vehicle.dynamics.engine.EnsembleSimulator`
(exact for linear structures, vectorised RK4 otherwise); this module maps distribution parameters
and germs onto them and batches several models into one pass. With the germs fixed, the moments
are smooth functions of the distribution and effect parameters, so optimisers can fit them.
"""

from __future__ import annotations

from dataclasses import replace
import numpy as np

from ..settings import ParameterLayout, Settings
from .effects import ModelStructure, shape_parts, with_tyre_shape
from .effects.terms import CHASSIS_FIELDS
from .single_track import STATES, VehicleParameters
from .dynamics.engine import EnsembleSimulator
from .track_rk4 import measured_channels, rk4_lateral_acceleration
from ..numerics.threads import beside, has_spare_core, spare_core
from ..numerics.sampled_input import INTERPOLATIONS, actual_steering, held_index, held_integral, reconstruction_error
from .uncertainty import Germs, kle_of_wind, uniform_from_germ

__all__ = ["THETA_NAMES", "INTERPOLATIONS", "Germs", "actual_steering", "held_index", "held_integral", "reconstruction_error", "AugmentedSimulator"]

#: Distribution parameters identified with every structure: mu ~ N, l_f ~ N, mean wind ~ U.
THETA_NAMES = ParameterLayout.names
#: Realisations of one RK4 pass of linear models along a speed profile: past a few thousand a
#: step's NumPy calls cost their arithmetic, and the half-step wind forces (2 steps x realisations) grow.
_PASS_REALISATIONS = 8000


class AugmentedSimulator(EnsembleSimulator):
    """Simulate an augmented single-track model for distribution parameters ``theta``.

    Parameters
    ----------
    settings : Settings
        The car's constants, the load distribution (fixed, not identified: the LST depends on
        the mass only through F_w / m), the wind and its KLE settings.
    germs : Germs
        Fixed germs of the realisations (common random numbers).
    time, delta, v_c, stride, interpolation, channels, speed, backend
        The grid, the commanded steering, the speed, the output and who integrates, as
        :class:`~uqdrive.vehicle.dynamics.engine.EnsembleSimulator` takes them.

    Attributes
    ----------
    output_time : ndarray, shape (K + 1,)
        Times (s) of the returned states.
    """

    def __init__(self, settings: Settings, time, delta, v_c: float, germs: Germs, stride: int = 1, interpolation: str = "linear",
                 channels=STATES, speed=None, backend: str = "numpy"):
        super().__init__(settings, time, delta, v_c, stride, interpolation, channels, speed, backend=backend)
        if germs.kle.shape[1] < self.kle.n_modes:
            raise ValueError(f"germs hold {germs.kle.shape[1]} KLE modes; the wind needs {self.kle.n_modes}")
        self.germs = germs
        self.load = settings.uncertainty.m_load
        self.m_load = self.load.mean + self.load.std * germs.m_load

    @classmethod
    def drawn(cls, settings: Settings, time, delta, v_c: float, n: int, rng: np.random.Generator, stride: int = 1,
              matched: bool = False, interpolation: str = "linear", channels=STATES, speed=None, backend: str = "numpy") -> "AugmentedSimulator":
        """A simulator on ``n`` germs drawn from ``rng`` (as many KLE modes as the horizon needs),
        moment-matched if ``matched`` (:meth:`Germs.matched`: for model ensembles, not for data)."""
        n_modes = kle_of_wind(settings.wind, float(np.asarray(time)[-1])).n_modes
        return cls(settings, time, delta, v_c, Germs.draw(rng, n, n_modes, matched), stride, interpolation, channels, speed, backend)

    def with_germs(self, germs: Germs) -> "AugmentedSimulator":
        """The same model on other germs (the KLE is reused)."""
        other = object.__new__(AugmentedSimulator)
        other.__dict__.update(self.__dict__)
        other.germs = germs
        other.m_load = self.load.mean + self.load.std * germs.m_load
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
        simulator's own), :meth:`realise` of :meth:`parameters`."""
        return self.realise(*self.parameters(theta, germs), structure)

    def simulate_many(self, thetas, structures, groups=None) -> list:
        """:meth:`simulate` for several (theta, structure) pairs, as one batch where the model
        is integrated numerically (one RK4 pass over all realisations of all pairs: a step's
        NumPy call overhead is paid once; at 300 realisations it is half the cost of a pass);
        pairs of different tyre shapes (b, C) in passes of one shape each, but chassis pairs in
        one pass whose realisations each carry their pair's stiffness and shape factors.

        ``groups``: numbers of consecutive pairs (summing to their count) that are computed as
        if each group were a call of its own: the pairs of a group get the same numbers, to the
        last bit, as ``simulate_many`` of that group alone (one pair: as :meth:`simulate`).
        Default: one group.
        """
        thetas, n = [np.asarray(th, float) for th in thetas], self.germs.n
        chassis = all(s.uses_chassis and s.nonlinear for s in structures)
        if len({s.tyre_shape() for s in structures}) > 1 and not (chassis and len(thetas) > 1):
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
        """:meth:`simulate_many` of pairs of different tyre shapes on the single-track model (its pass shares one B and C): each group's
        pairs of one shape in one call."""
        out = [None] * len(thetas)
        parts = shape_parts(structures, groups)
        if has_spare_core():  # the parts on two cores
            return self._on_two_cores(thetas, structures, parts)
        for m in parts:
            for i, x in zip(m, self.simulate_many([thetas[i] for i in m], [structures[i] for i in m])):
                out[i] = x
        return out

    def _on_two_cores(self, thetas, structures, parts) -> list:
        """:meth:`simulate_many` of each part (lists of pair indices) on two cores (:func:`beside`),
        the largest part of chassis pairs (each pair its own group in its pass, :meth:`_in_passes`)
        cut in two, the parts shared out longest first by their cost: a pass costs about one pair
        more than its pairs (the per-step calls), so a pair alone costs nearly twice its share."""
        units = sorted(parts, key=len, reverse=True)
        if len(units[0]) > 1 and all(structures[i].uses_chassis and structures[i].nonlinear for i in units[0]):
            half = (len(units[0]) + 1) // 2
            units = sorted([units[0][:half], units[0][half:], *units[1:]], key=len, reverse=True)
        sides, cost = ([], []), [0, 0]
        for m in units:
            k = cost.index(min(cost))
            sides[k].append(m)
            cost[k] += 1 + len(m)

        def run(side):
            with spare_core(False):
                return [self.simulate_many([thetas[i] for i in m], [structures[i] for i in m]) for m in side]

        out = [None] * len(thetas)
        for side, sims in zip(sides, beside(run, sides)):
            for m, xs in zip(side, sims):
                for i, x in zip(m, xs):
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
                one_pass = lambda m: self._one_pass([thetas[i] for i in m], [structures[i] for i in m], [self.germs.n] * len(m), **options)  # noqa: E731
                if has_spare_core():  # half the pairs on the spare core: a pass of either half gives each pair the same numbers
                    half = (len(part) + 1) // 2
                    sims = [x for sims in beside(one_pass, [part[:half], part[half:]]) for x in sims]
                else:
                    sims = one_pass(part)
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
        return [measured_channels(x[:, i * n:(i + 1) * n], None, s, STATES) for i, s in enumerate(structures)]

    def _batch(self, thetas, structures, chassis: bool = False):
        """Parameters, mean wind, gust coefficients and one structure (its per-pair fields as
        arrays of n per pair) of the pairs' realisations side by side; pairs of different tyre
        shapes (chassis passes) give each realisation its pair's stiffness and shape factors."""
        n = self.germs.n
        parts = [self.parameters(th) for th in thetas]
        p = replace(parts[0][0], mu=np.concatenate([q[0].mu for q in parts]), l_f=np.concatenate([q[0].l_f for q in parts]),
                    m_load=np.concatenate([np.broadcast_to(q[0].m_load, (n,)) for q in parts]))
        if len({s.tyre_shape() for s in structures}) > 1:
            shaped = [with_tyre_shape(p, s) for s in structures]
            p = replace(p, **{f: np.repeat([getattr(q, f) for q in shaped], n) for f in ("c_Sf", "c_Sr", "C")})
        else:
            p = with_tyre_shape(p, structures[0])
        wind = np.concatenate([q[1] for q in parts])
        coeffs = np.concatenate([q[2] * s.gust_scale for q, s in zip(parts, structures)])
        per = lambda attr, default: np.repeat([default if getattr(s, attr) is None else getattr(s, attr) for s in structures], n)  # noqa: E731
        fields = {"tyre_curvature": self.car.E, "lateral_acceleration": 0.0, "course_weight": 0.0}
        if chassis:
            fields.update({f: 0.0 for f in CHASSIS_FIELDS})
        return p, wind, coeffs, replace(structures[0], **{f: per(f, d) for f, d in fields.items()})

    def _chassis_kind(self, s: ModelStructure):
        """What must be equal for pairs to share an RK4 pass of the chassis right-hand side: the
        tyre, the kinematics, which terms are on, the step; None: not a chassis structure."""
        if not s.uses_chassis:
            return None
        return (s.tyre, bool(s.course_exact), s.chassis_switches(), self._substeps(s))


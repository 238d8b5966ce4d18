"""Fit the distributions of mu, l_f and the mean wind, and the parameters of an added effect, to
measured mean and std trajectories with the augmented model on common random numbers.

The residuals are the gaps in units of the null band (:mod:`.band`), so the cost is a chi-square
that is comparable across candidate effects; trust-region least squares with bounds.
"""

from __future__ import annotations

import numpy as np

from ...settings import ParameterLayout
from ...vehicle.augmented import THETA_NAMES, AugmentedSimulator
from ...vehicle.effects import Effect, ModelStructure
from .band import compared_times, mean_std
from .ranking import ResolutionStop, resolved_least_squares

__all__ = ["THETA_BOUNDS", "THETA_SCALE", "SpreadCoordinates", "StructureFit"]

#: Bounds of the distribution parameters (mu mean/std, l_f mean/std in m, wind bounds in N).
THETA_BOUNDS = ParameterLayout.bounds
#: Typical magnitudes, so that the optimiser steps every parameter alike.
THETA_SCALE = ParameterLayout.scales


class SpreadCoordinates:
    """Search coordinates of theta with its spreads squared: each std's square (a variance), the
    mean wind's bounds as their centre and squared width; the held (known) ones as they are.

    The moments depend on a spread through its square, so in theta the Jacobian column of a
    spread the data do not want vanishes as it shrinks and trf creeps towards zero for its
    whole budget; in the squares the column stays finite and trf reaches the optimum.
    """

    def __init__(self, fixed=()):
        self.stds = [i for i in (1, 3) if i not in fixed]
        self.wind = 4 not in fixed and 5 not in fixed

    def forward(self, x):
        """Search coordinates of parameters ``x`` (theta first, then any effect's)."""
        u = np.array(x, float)
        u[self.stds] = u[self.stds] ** 2
        if self.wind:
            u[4], u[5] = 0.5 * (x[4] + x[5]), (x[5] - x[4]) ** 2
        return u

    def inverse(self, u):
        """Parameters (theta first, the wind's bounds in order) of search coordinates ``u``."""
        x = np.array(u, float)
        x[self.stds] = np.sqrt(np.maximum(u[self.stds], 0.0))
        if self.wind:
            half = 0.5 * np.sqrt(max(u[5], 0.0))
            x[4], x[5] = u[4] - half, u[4] + half
        return x

    def box(self, lo, hi, typical):
        """Bounds and typical magnitudes of the coordinates from theta's: a std's squared; the
        wind's centre within the bounds' range, its squared width up to the range's square."""
        lo, hi, typical = self.forward(lo), np.array(hi, float), np.array(typical, float)
        hi[self.stds], typical[self.stds] = hi[self.stds] ** 2, typical[self.stds] ** 2
        if self.wind:
            hi[4], hi[5], typical[5] = hi[5], (hi[5] - THETA_BOUNDS[4][0]) ** 2, typical[5] ** 2
        return lo, hi, typical

    def steps(self, u, h, scale):
        """Forward-difference steps of coordinates ``u`` (``h``: the others'): a squared spread s
        steps by (s + d)^2 - s^2, d = 1e-4 max(s, its ``scale``), the step theta takes; 1e-4 of
        a squared scale would be a spread of 1 % of the scale at s = 0, past the map's curvature."""
        x, h = self.inverse(u), np.array(h, float)
        for i, s in [(i, x[i]) for i in self.stds] + ([(5, x[5] - x[4])] if self.wind else []):
            d = 1e-4 * max(abs(s), scale[i])
            h[i] = d * (2.0 * abs(s) + d)
        return h

    def derivative(self, u):
        """d u / d theta (p, p) at coordinates ``u``, for the chain rule of a Jacobian."""
        x, d = self.inverse(u), np.eye(len(u))
        d[self.stds, self.stds] = 2.0 * x[self.stds]
        if self.wind:
            d[4, 4:6], d[5, 4:6] = 0.5, (-2.0 * (x[5] - x[4]), 2.0 * (x[5] - x[4]))
        return d


class StructureFit:
    """Least-squares fit of an augmented single-track model to measured moment statistics.

    Parameters
    ----------
    simulator : AugmentedSimulator
        Model realisations on fixed germs (common random numbers) on the data's grid.
    index : ndarray of int, shape (K,)
        Time indices compared.
    noise_variance : ndarray, shape (C,)
        Measurement-noise variance per measured channel (the simulator's ``channels``; added to
        the model's variance).
    spin_threshold : float or None
        |beta| (rad) beyond which a model realisation lost control and is excluded, as the data's
        (None where beta is not measured: the data cannot tell which runs spun).
    effect : Effect, optional
        The effect added to ``base`` whose parameters are fitted with theta; None fits theta only.
    base : ModelStructure
    fit_theta : bool
        False keeps theta at its start (screening of an effect at the baseline's estimate).
    max_nfev : int
        Budget of model evaluations.
    fixed : mapping of int to float, optional
        Known distribution parameters (index into :data:`THETA_NAMES` -> value): held at their
        value, not fitted (their columns of ``jacobian_`` are zero).
    memo : SimulationMemo, optional
        Linear models' simulations shared with other fits on the same simulator
        (:class:`.fitter.SimulationMemo`).
    resolution : float, optional
        chi2 (its units) of no consequence where the fit is used (:func:`.ranking.resolved_least_squares`).
    hopeless_above : float, optional
        chi2 (its units) it must come below to matter; it stops where it cannot (``success_`` False).

    Attributes
    ----------
    theta_ : ndarray, shape (6,)
        Fitted distribution parameters in :data:`THETA_NAMES` order (|std|, wind bounds sorted).
    effect_values_ : ndarray, shape (n_effect,)
    structure_ : ModelStructure
    statistics_ : ndarray, shape (2, C, K)
        Model [mean, std] at the estimate.
    measured_, scale_ : ndarray, shape (2, C, K)
        The measured statistics and the null-band scale the fit was given.
    z_ : ndarray, shape (2, C, K)
        Standardised gap at the estimate.
    chi2_ : float
        sum(z_^2).
    jacobian_ : ndarray, shape (2 * C * K, p)
        d z / d parameters at the estimate (the null band projects it out of bootstrap replicates).
    parameter_cov_ : ndarray, shape (p, p)
        Gauss-Newton covariance (J'J)^-1 of all fitted parameters (theta first) in z units.
    nfev_, status_ : int
        Evaluations; trf's status, :class:`.ranking.ResolutionStop`'s (5 resolved, 6 out of reach), 1 where nothing was free.
    success_ : bool
    message_ : str
    """

    #: Whether a fit not converged within THETA_EVALUATIONS goes on in the spreads' squares
    #: (:class:`SpreadCoordinates`); False: theta alone for the whole budget.
    spread_as_variance = True
    #: Evaluations searched in theta itself: a fit that converges within them (as the converging
    #: fits of the benchmark jobs do) keeps the numbers of a search in theta alone.
    THETA_EVALUATIONS = 40

    def __init__(self, simulator: AugmentedSimulator, index, noise_variance, spin_threshold=None, effect: Effect | None = None,
                 base: ModelStructure = ModelStructure(), fit_theta: bool = True, max_nfev: int = 200, fixed=None,
                 memo=None, resolution: float | None = None, hopeless_above: float | None = None):
        self.simulator = simulator
        self.resolution, self.hopeless_above = resolution, hopeless_above
        self.memo = memo
        self.fixed = {int(k): float(v) for k, v in (fixed or {}).items()} if fit_theta else {}
        self.index = np.asarray(index, int)
        self.noise_variance = np.asarray(noise_variance, float)
        self.spin_threshold = spin_threshold
        self.effect, self.base, self.fit_theta = effect, base, fit_theta
        self.max_nfev = int(max_nfev)
        self._cache, self._ahead = {}, None  # simulations by key; (keys, simulations) simulated ahead of a call (_simulate)

    def __getstate__(self):  # what a worker sends back (inference.parallel): no simulations
        return {**self.__dict__, "_cache": {}, "_ahead": None}

    @property
    def parameter_names(self) -> tuple:
        """Names of the fitted parameters: the distribution parameters (if fitted), then the effect's."""
        names = THETA_NAMES if self.fit_theta else ()
        return names + (self.effect.parameters if self.effect is not None else ())

    @property
    def parameter_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper bounds of the fitted parameters (``parameter_names`` order)."""
        bounds = (THETA_BOUNDS if self.fit_theta else ()) + (tuple(self.effect.bounds) if self.effect is not None else ())
        return np.array([b[0] for b in bounds], float), np.array([b[1] for b in bounds], float)

    def structure(self, effect_values=()) -> ModelStructure:
        """The model structure with the effect at ``effect_values`` (the base structure without an effect)."""
        if self.effect is None:
            return self.base
        return self.effect.augment(self.base, effect_values)

    @staticmethod
    def _dynamic(structure: ModelStructure) -> ModelStructure:
        """The structure without its output map (the part that needs a simulation)."""
        return ModelStructure(**{**structure.__dict__, "output_offset": (0.0,) * 4, "output_gain": (1.0,) * 4, "effects": (),
                                 "a_y_offset": 0.0, "a_y_gain": 1.0})

    def _keys(self, pairs):
        return [(np.asarray(th, float).tobytes(), self._dynamic(s)) for th, s in pairs]

    def _todo(self, keys, cached):
        """Indices of ``keys`` to simulate given the ``cached`` keys, and whether the cache (at
        most 64 simulations) is emptied first, in which case all of them are simulated."""
        todo = [i for i, k in enumerate(keys) if k not in cached]
        if len(cached) + len(todo) > 64:
            return list(range(len(keys))), True
        return todo, False

    def _simulate(self, pairs, then=()):
        """Simulations of (theta, structure) pairs, cached by their dynamic part, batched.

        ``then``: the pairs the next call will ask for (a Jacobian's difference neighbours after
        the residuals at their centre). Those it would simulate are simulated in this call's
        pass, as a group of their own (:meth:`AugmentedSimulator.simulate_many`: the numbers of
        a call of their own), and kept aside; the next call takes them if it asks for exactly
        them, else they are dropped. The cache fills and empties as without ``then``, so every
        simulation has the numbers it would have had.
        """
        keys = self._keys(pairs)
        todo, clear = self._todo(keys, self._cache)
        if not todo:  # all cached (the residuals at the centre just simulated): ahead stays
            return [self._cache[k] for k in keys]
        ahead, self._ahead = self._ahead, None
        if clear:
            self._cache.clear()
        if ahead is not None and ahead[0] == [keys[i] for i in todo]:
            sims = ahead[1]
        else:
            later = []
            if then:  # what the next call would simulate, unless it would empty the cache
                cached = set(self._cache) | {keys[i] for i in todo}
                then_keys = self._keys(then)
                later, again = self._todo(then_keys, cached)
                later = [] if again else [(then[i], then_keys[i]) for i in later]
            batch = [(pairs[i][0], keys[i][1]) for i in todo] + [(pair[0], key[1]) for pair, key in later]
            if self.memo is not None and not any(st.nonlinear for _, st in batch):
                sims = self._linear_simulations([keys[i] for i in todo] + [key for _, key in later], batch)
            else:
                sims = self.simulator.simulate_many([th for th, _ in batch], [st for _, st in batch],
                                                    groups=[len(todo)] + ([len(later)] if later else []))
            if later:
                self._ahead = ([key for _, key in later], sims[len(todo):])
        for i, x in zip(todo, sims):
            self._cache[keys[i]] = x
        return [self._cache[k] for k in keys]

    def _linear_simulations(self, keys, batch):
        """Simulations of linear (theta, dynamic structure) pairs, those another fit made taken
        from the memo (each is a call of its own either way: the same numbers)."""
        sims = [self.memo.get(self.simulator, k) for k in keys]
        todo = [i for i, x in enumerate(sims) if x is None]
        if todo:  # one batch: along a speed profile one RK4 pass (simulate_many), else one call each
            made = self.simulator.simulate_many([batch[i][0] for i in todo], [batch[i][1] for i in todo])
            for i, x in zip(todo, made):
                sims[i] = x
                self.memo.put(self.simulator, keys[i], x)
        return sims

    def statistics(self, theta, structure: ModelStructure):
        """Model [mean, std] (2, C, K) with the noise variance added to the model's variance."""
        return self._measured_statistics(self._simulate([(theta, structure)])[0], structure)

    def statistics_many(self, thetas, structures, batch: int = 32):
        """:meth:`statistics` of many (theta, structure) pairs, shape (B, 2, C, K); simulated in
        batches of ``batch`` pairs (one RK4 pass each for a non-linear tyre), bypassing the cache."""
        out = []
        for start in range(0, len(thetas), batch):
            th, st = list(thetas[start:start + batch]), list(structures[start:start + batch])
            sims = self.simulator.simulate_many(th, [self._dynamic(s) for s in st])
            out += [self._measured_statistics(x, s) for x, s in zip(sims, st)]
        return np.array(out)

    def _measured_statistics(self, x, structure: ModelStructure):
        """[mean, std] (2, C, K) of realisations x (4, n, T) as measured: spun ones excluded,
        the structure's output map applied, the noise variance added."""
        if self.spin_threshold is not None:
            keep = ~np.any(np.abs(x[self.simulator.spin_row]) > self.spin_threshold, axis=-1)
            if keep.sum() >= 2 and not keep.all():  # else all realisations
                x = x[:, keep]
        gain, offset = structure.output_map(self.simulator.channels)
        gain = gain[:, None]
        stats = mean_std(compared_times(x, self.index))  # the compared times read where they lie
        mean = stats[0] * gain + offset[:, None]
        std = np.sqrt((stats[1] * gain) ** 2 + self.noise_variance[:, None])
        return np.stack([mean, std])

    def _split(self, params, theta0):
        params = np.asarray(params, float)
        if self.fit_theta:
            return params[:6], params[6:]
        return np.asarray(theta0, float), params

    def _misfit(self, params, theta0, measured, scale):
        """The standardised gaps z (flattened) of parameters ``params`` (theta first)."""
        theta, ev = self._split(params, theta0)
        return ((self.statistics(theta, self.structure(ev)) - measured) / scale).ravel()

    def _search(self, x0, free, lo, hi, typical, spread, budget, theta0, measured, scale):
        """trf from parameters ``x0`` (theta first) over the ``free`` ones within [lo, hi], in
        theta itself (``spread`` None) or in :class:`SpreadCoordinates`, for at most ``budget``
        evaluations. Returns the parameters, d z / d parameters (zero columns for the held
        ones), the evaluations, trf's status and message."""
        theta_typical = typical
        unit = np.ones(x0.size)  # trf's variables are the coordinates in these units
        if spread is not None:  # the search in the spreads' squares (a point inside theta's box is inside theirs)
            x0, (lo, hi, typical) = spread.forward(x0), spread.box(lo, hi, typical)
            # in units of their typical magnitudes: trf's xtol compares a step with the norm of
            # its variables, which a squared wind width (~1e5 N^2) would otherwise dominate
            unit = typical

        def whole(params):
            """The whole search vector from the free coordinates (the known ones at their values)."""
            if free.all():
                return np.asarray(params, float) * unit
            out = x0.copy()
            out[free] = params * unit[free]
            return out

        def full(params):
            """The model's parameter vector (theta first) of the free search coordinates."""
            u = whole(params)
            return u if spread is None else spread.inverse(u)

        def difference_points(u):
            """The point and its forward-difference neighbours in the free search coordinates
            ``u`` (whole vector), with the steps; the points as model parameters."""
            h = 1e-4 * np.maximum(np.abs(u), typical)
            if spread is not None:  # a squared spread: the square of the spread's own step (not 1e-4 of a squared scale)
                h = spread.steps(u, h, theta_typical)
            h = np.where(u + h > hi, -h, h)
            h[~free] = 0.0
            points = [u] + [u + h[i] * np.eye(u.size)[i] for i in np.flatnonzero(free)]
            return h, points if spread is None else [spread.inverse(pt) for pt in points]

        def pairs(points):
            return [(th, self.structure(ev)) for th, ev in (self._split(pt, theta0) for pt in points)]

        # A numerically integrated model simulates a point's difference neighbours in the pass
        # of the point itself: trf asks for the Jacobian at every point whose residuals it
        # accepts (it rejected none in the benchmark's fits), and one RK4 pass over 8 x 300
        # realisations costs a tenth more than the 7 x 300 of the Jacobian alone. Along a speed
        # profile a linear model is integrated by RK4 as well, its pairs batched alike.
        ahead = self.structure(x0[6:] if self.fit_theta else x0).nonlinear or getattr(self.simulator, "speed", None) is not None

        def residuals(params):
            u = whole(params)
            if ahead:
                points = difference_points(u)[1]
                self._simulate(pairs(points[:1]), then=pairs(points[1:]))
            return self._misfit(full(params), theta0, measured, scale)

        def jacobian(params):
            """Forward differences in the free coordinates, all perturbed models simulated in one batch."""
            h, points = difference_points(whole(params))
            self._simulate(pairs(points))
            f = [self._misfit(pt, theta0, measured, scale) for pt in points]
            return np.column_stack([(fi - f[0]) / hi_ for fi, hi_ in zip(f[1:], h[free])]) * unit[free]

        u = unit[free]
        point, found, nfev, status, message = resolved_least_squares(residuals, jacobian, x0[free] / u, (lo[free] / u, hi[free] / u),
                                                                     typical[free] / u, budget, self.resolution, self.hopeless_above)
        jac = np.zeros((found.shape[0], x0.size))
        jac[:, free] = found / u
        if spread is not None:  # d z / d theta by the chain rule through the squares
            jac = jac @ spread.derivative(whole(point))
        return full(point), jac, nfev, status, message

    def fit(self, measured, scale, theta0, effect_start=None) -> "StructureFit":
        """Fit from ``theta0`` (and the effect's start values); ``measured``, ``scale`` (2, C, K)."""
        measured, scale = np.asarray(measured, float), np.asarray(scale, float)
        theta0 = np.clip(np.asarray(theta0, float), [b[0] for b in THETA_BOUNDS], [b[1] for b in THETA_BOUNDS])
        eff = self.effect
        e_start = np.asarray(eff.start if effect_start is None else effect_start, float) if eff is not None else np.zeros(0)
        typical = list(THETA_SCALE) if self.fit_theta else []
        if eff is not None:
            typical += [max(abs(s), (b[1] - b[0]) / 20.0) for s, b in zip(eff.start, eff.bounds)]
        x0 = np.concatenate([theta0 if self.fit_theta else np.zeros(0), e_start])
        lo, hi = self.parameter_bounds
        x0 = np.clip(x0, lo + 1e-9 * (hi - lo), hi - 1e-9 * (hi - lo))
        for i, v in self.fixed.items():
            x0[i] = v  # a known value is used as given (a std of 0 sits on its bound)
        free = np.array([i not in self.fixed for i in range(x0.size)], bool)
        typical = np.array(typical, float)
        if not free.any():
            x, jac, nfev, status, message = x0, np.zeros((self._misfit(x0, theta0, measured, scale).size, x0.size)), 1, 1, "nothing to fit"
        else:
            # theta first, within THETA_EVALUATIONS; a fit still searching goes on in the spreads' squares
            first = self.max_nfev if not (self.fit_theta and self.spread_as_variance) else min(self.max_nfev, self.THETA_EVALUATIONS)
            x, jac, nfev, status, message = self._search(x0, free, lo, hi, typical, None, first, theta0, measured, scale)
            if status == 0 and nfev < self.max_nfev and first < self.max_nfev:
                spread = SpreadCoordinates(self.fixed)
                x, jac, more, status, message = self._search(x, free, lo, hi, typical, spread, self.max_nfev - nfev, theta0, measured, scale)
                nfev += more
        theta, ev = self._split(x, theta0)
        theta = theta.copy()
        theta[[1, 3]] = np.abs(theta[[1, 3]])  # the moments are even in each std (FACTS)
        theta[4:6] = np.sort(theta[4:6])
        self.theta_ = theta
        self.measured_, self.scale_ = measured, scale
        self.effect_values_ = np.asarray(ev, float)
        self.structure_ = self.structure(self.effect_values_)
        self.statistics_ = self.statistics(theta, self.structure_)
        self.z_ = (self.statistics_ - measured) / scale
        self.chi2_ = float(np.sum(self.z_**2))
        self.jacobian_ = np.asarray(jac, float)
        try:
            self.parameter_cov_ = np.linalg.pinv(jac.T @ jac) if jac.size else np.zeros((0, 0))
        except np.linalg.LinAlgError:
            self.parameter_cov_ = np.full((x.size, x.size), np.nan)
        self.nfev_, self.status_, self.message_, self.success_ = int(nfev), int(status), message, bool(0 < status != ResolutionStop.OUT_OF_REACH)
        return self

    def effect_intervals(self, inflation: float = 1.0, level_z: float = 1.959963984540054):
        """{parameter: [estimate, lo95, hi95]} of the effect's parameters; the Gauss-Newton
        covariance is multiplied by ``inflation`` (correlation of the residuals in time)."""
        if self.effect is None:
            return {}
        offset = 6 if self.fit_theta else 0
        out = {}
        for i, name in enumerate(self.effect.parameters):
            var = self.parameter_cov_[offset + i, offset + i] * inflation if self.parameter_cov_.size else np.nan
            half = level_z * float(np.sqrt(max(var, 0.0))) if np.isfinite(var) else float("nan")
            v = float(self.effect_values_[i])
            out[name] = [v, v - half, v + half]
        return out

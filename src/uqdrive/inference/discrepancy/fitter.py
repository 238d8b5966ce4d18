"""The candidate fits of one dataset: the baseline, joint fits of the distributions with a set of
effects, short probes of non-linear candidates, the screening and one forward step's pool, and
the linear simulations they share.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Mapping, Sequence

import numpy as np

from ...numerics.threads import spare_core
from ...vehicle.augmented import THETA_NAMES
from ...vehicle.effects import EFFECTS, ModelStructure
from ..parallel import fork_map
from .comparison import Compared, ModelComparison, criterion
from .effectset import EffectSet, fitted_values
from .fit import StructureFit
from .ranking import RESOLVED_SHARE, ResolutionStop, screen

__all__ = ["PROBE_NFEV", "PROBE_SHARE", "CandidateFitter", "SimulationMemo", "in_reach", "nonlinear", "reach_bar"]

#: A non-linear candidate is first fitted with this budget of model evaluations (:meth:`CandidateFitter.probe`), then finished only
#: when it closed PROBE_SHARE of what the best linear candidate closed (its chi2 can only fall further).
PROBE_NFEV, PROBE_SHARE = 6, 0.25


class SimulationMemo:
    """Simulations of linear models shared by the fits of one dataset, the most recent ``size``.

    A linear model gets the numbers of a call of its own (:meth:`~uqdrive.vehicle.augmented.AugmentedSimulator.simulate_many`
    gives every linear pair those of :meth:`~uqdrive.vehicle.augmented.AugmentedSimulator.simulate`), so its realisations are a function of the
    simulator, theta and the structure's dynamic part alone: a fit that asks for one another fit
    already simulated (a screening held at the same distributions, an effect on the outputs only,
    a refit from the point a short fit stopped at) gets the same array, bit for bit. Entries hold
    their simulator, so a key's ``id`` cannot be reused by another simulator while it is stored.
    """

    def __init__(self, size: int = 32):
        self.size = int(size)
        self._entries: dict = {}

    def get(self, simulator, key):
        """The stored simulation of ``key`` on ``simulator`` (moved to the most recent), or None."""
        entry = self._entries.pop((id(simulator), key), None)
        if entry is None or entry[0] is not simulator:
            return None
        self._entries[(id(simulator), key)] = entry
        return entry[1]

    def put(self, simulator, key, x) -> None:
        """Store ``x``, the simulation of ``key`` on ``simulator``, dropping the oldest beyond ``size``."""
        self._entries.pop((id(simulator), key), None)
        self._entries[(id(simulator), key)] = (simulator, x)
        while len(self._entries) > self.size:
            self._entries.pop(next(iter(self._entries)))


def nonlinear(name: str) -> bool:
    """Whether the registered effect ``name`` needs numerical integration (at its start values)."""
    return EFFECTS[name].augment(ModelStructure(), EFFECTS[name].start).nonlinear


def reach_bar(comparison: ModelComparison, cur, others) -> float | None:
    """The chi2 a non-linear candidate's short fit must reach to be worth finishing: ``cur``'s
    less :data:`PROBE_SHARE` of what the best of ``others`` (the linear candidates) closed;
    None where none of them closed anything (every probe is finished)."""
    chi2 = comparison.chi2
    gain = chi2(cur) - min((chi2(f) for f in others), default=chi2(cur))
    return None if gain <= 0 else chi2(cur) - PROBE_SHARE * gain


def in_reach(comparison: ModelComparison, cur, probe, others) -> bool:
    """Whether a non-linear candidate's short fit is worth finishing: it already closed at
    least :data:`PROBE_SHARE` of what the best linear candidate closed (a full fit only
    lowers chi2 further), or no linear candidate closed anything (:func:`reach_bar`)."""
    bar = reach_bar(comparison, cur, others)
    return bar is None or comparison.chi2(probe) <= bar


def _better_start(starts, chi2):
    """A probe's result from the fits of its starts: the one lower by ``chi2``, and whether a
    start stopped out of reach."""
    return min(starts, key=chi2), any(getattr(f, "status_", None) == ResolutionStop.OUT_OF_REACH for f in starts)


class CandidateFitter:
    """Least-squares fits of the distributions, alone or jointly with effects, on one dataset.

    Parameters
    ----------
    data : Compared
        The measured statistics, scales, simulators and compared grid.
    known : mapping of int to float
        Distribution parameters held at their known value (index into ``THETA_NAMES``).
    start : sequence of float, length 6
        The distributions' start (the prior's, or a start model's): the second start of a probe
        and an anchor of the screening.
    tyre_E : float
        The car's Magic-Formula curvature, at which a saturating tyre is screened.
    top : int
        Linear candidates re-identified jointly per forward step.
    memo : SimulationMemo, optional
        Linear simulations shared by the fits (:meth:`release` drops it).
    jobs : int
        Worker processes for the independent fits of a step (:func:`uqdrive.inference.parallel.fork_map`: the
        same numbers as one after the other).

    Attributes
    ----------
    resolution : float or None
        chi2 on the linear footing below which a fit's remaining decrease does not matter
        (:meth:`resolve_at`); None until the null band is known: every fit runs to trf's tolerances.
    reach_bar : float or None
        The last :meth:`fit_pool`'s :func:`reach_bar`: its probes stopped where they could not reach it.
    unfinished : dict
        The last :meth:`fit_pool`'s non-linear candidates whose probe stopped out of reach, with
        what :meth:`finish` needs to fit them as without the stop.
    probe_stopped : bool
        Whether a start of the last :meth:`probe` stopped out of reach.
    """

    def __init__(self, data: Compared, known: Mapping[int, float], start: Sequence[float], tyre_E: float, top: int,
                 memo: SimulationMemo | None = None, jobs: int = 1):
        self.data = data
        self.jobs = int(jobs)
        self.known = dict(known)
        self.start = start
        self.tyre_E = tyre_E
        self.top = int(top)
        self.memo = memo
        self.resolution = None
        self.reach_bar, self.unfinished, self.probe_stopped, self._unfinished_of = None, {}, False, None

    def resolve_at(self, band) -> None:
        """Stop the candidates' fits at the resolution of the comparisons made with ``band``.

        :data:`.ranking.RESOLVED_SHARE` of its chi2 standard deviation: every choice among fits
        (the tie margin, a step's justification, the backward check) compares chi2 differences
        with 2 of them, so a fit that stops this short of its optimum moves a comparison by at
        most a fortieth of the margin. The baseline, whose residuals and Jacobian make the band,
        is fitted before and not stopped."""
        self.resolution = RESOLVED_SHARE * float(band.chi2_null_sd)

    def _resolution(self, wide: bool):
        """The resolution in the chi2 of a fit on the footing of ``wide``: a numerically
        integrated model's excess counts its squared scale ratio on the linear footing
        (:meth:`.comparison.ModelComparison.chi2`), so its tolerance shrinks by that ratio."""
        if self.resolution is None:
            return None
        d = self.data
        return self.resolution / float(np.mean((d.scale_for(wide) / d.scale) ** 2))

    def release(self) -> None:
        """Drop the shared simulations (a posterior batches its own)."""
        self.memo = None

    def map(self, fn, items) -> list:
        """``[fn(item) for item in items]`` on :attr:`jobs` worker processes; the fits they return
        hold this fitter's simulators and memo (:func:`uqdrive.inference.parallel.fork_map`)."""
        items = list(items)
        if self.jobs <= 1 or len(items) <= 1:  # no fork: the shared objects below (a simulator built for them) are not needed
            with spare_core(self.jobs > 1):  # one item on several workers: its RK4 passes in halves on two cores
                return [fn(item) for item in items]
        d = self.data
        return fork_map(fn, items, self.jobs, (d, d.sim, d.raw_germs, d.sim_for(True), self.memo, *EFFECTS.values()))

    def baseline(self, theta0) -> StructureFit:
        """The distributions alone fitted from ``theta0`` (the known ones held)."""
        d = self.data
        return StructureFit(d.sim, d.index, d.noise, d.spin, fixed=dict(self.known), memo=self.memo).fit(d.measured, d.scale, theta0)

    def joint(self, theta_start, names, values, max_nfev: int | None = None, release=(), hopeless_above=None) -> StructureFit:
        """Distributions and the parameters of every effect in ``names`` fitted jointly; a parameter
        with one physical value is held there (:meth:`.effectset.EffectSet.physical`) unless its effect is in ``release``.
        ``hopeless_above``: a callable (wide -> chi2 on that footing's scale, :meth:`.comparison.ModelComparison.chi2_bar`)
        giving the chi2 the fit must come below to matter (None: it runs its course)."""
        d = self.data
        eff = EffectSet(names, {k: values[k] for k in names if k in values})
        held = {len(THETA_NAMES) + i: v for i, v in eff.physical(release).items()}
        # the footing follows the names, not the start values: a non-linear effect that starts
        # at zero size (refitted after its fit went there) may grow during the fit
        wide = any(nonlinear(k) for k in names)
        budget = max_nfev or (25 if wide else 60)
        f = StructureFit(d.sim_for(wide), d.index, d.noise, d.spin, effect=eff, max_nfev=budget,
                         fixed={**dict(self.known), **held}, memo=self.memo, resolution=self._resolution(wide),
                         hopeless_above=None if hopeless_above is None else hopeless_above(wide))
        return f.fit(d.measured, d.scale_for(wide), theta_start)

    def probe(self, theta, names, values, chi2, hopeless_above=None) -> StructureFit:
        """Short joint fit (:data:`PROBE_NFEV`) from ``theta`` and from the start's distributions, the one lower by ``chi2``: a
        linear baseline lowers mu to mimic saturation, a poor basin for a saturating tyre (the thesis' NLST data: chi2 5x the baseline's).
        ``hopeless_above``: as :meth:`joint`, each start stopped where it cannot reach it."""
        best, self.probe_stopped = _better_start([self.joint(th, names, values, max_nfev=PROBE_NFEV, hopeless_above=hopeless_above)
                                                  for th in (theta, self.start)], chi2)
        return best

    def _nonlinear_fits(self, comparison, cur, todo: dict, bar) -> dict:
        """Non-linear candidates' fits of :meth:`fit_pool`, ``todo`` {candidate: (names, values,
        linear fits)}: each one's :meth:`probe` (each start stopped out of reach of ``bar``, None:
        not), finished when in reach. Every probe's two starts go to the workers at once, then
        the fits that finish them. Returns {candidate: (fit, whether a start stopped)}."""
        hopeless = None if bar is None else (lambda wide: comparison.chi2_bar(bar, wide))
        starts = [(c, th) for c in todo for th in (cur.theta_, self.start)]
        made = self.map(lambda s: self.joint(s[1], todo[s[0]][0], todo[s[0]][1], max_nfev=PROBE_NFEV, hopeless_above=hopeless), starts)
        out = {c: list(_better_start(made[2 * k: 2 * k + 2], comparison.chi2)) for k, c in enumerate(todo)}
        ahead = [c for c in todo if in_reach(comparison, cur, out[c][0], todo[c][2])]
        for c, f in zip(ahead, self.map(lambda c: self.joint(out[c][0].theta_, todo[c][0], fitted_values(out[c][0])), ahead)):
            out[c][0] = f
        return {c: tuple(v) for c, v in out.items()}

    def finish(self, fits: dict) -> dict:
        """``fits`` with each probe :meth:`fit_pool` stopped out of reach (:attr:`unfinished`)
        fitted as without the stop, for a choice that reads more of them than whether they are
        in reach (their order, a tie, a pair)."""
        out = dict(fits)
        if self.unfinished:
            (comparison, cur), todo = self._unfinished_of, dict(self.unfinished)
            out.update({c: f for c, (f, _) in self._nonlinear_fits(comparison, cur, todo, None).items()})
        self.unfinished = {}
        return out

    def screen(self, cur, pool) -> dict:
        """Rank the candidates by the prediction of their joint fit (:func:`.ranking.screen`), held at ``cur``'s distributions
        and at the start's (the prior or the start model's, the one estimate no misfit has bent), a non-linear tyre linearised."""
        d = self.data
        start = np.asarray(self.start, float)
        anchors = {"current": np.asarray(cur.theta_, float), **({} if np.allclose(start, cur.theta_, rtol=1e-9, atol=1e-12) else {"start": start})}
        base = replace(cur.structure_, tyre="linear")  # a non-linear tyre's linearisation: a cheap ranking

        def held(name, theta):
            structure = EFFECTS[name].augment(base, EFFECTS[name].start)
            f = StructureFit(d.sim_for(structure.nonlinear), d.index, d.noise, d.spin, effect=EFFECTS[name], base=base,
                             fit_theta=False, max_nfev=40, memo=self.memo, resolution=self._resolution(structure.nonlinear))
            return f.fit(d.measured, d.scale_for(structure.nonlinear), theta)

        fixed = {c: [self.tyre_E] if c == "tyre_saturation" else list(EFFECTS[c].start) for c in pool if nonlinear(c)}
        pairs = [(c, label) for c in pool if c not in fixed for label in anchors]  # every held fit screen asks for, made at once
        made = dict(zip(((c, anchors[label].tobytes()) for c, label in pairs), self.map(lambda pair: held(pair[0], anchors[pair[1]]), pairs)))
        return screen(cur, pool, anchors, lambda name, theta: made[name, np.asarray(theta, float).tobytes()], fixed)

    def fit_pool(self, comparison: ModelComparison, cur, cur_band, pool, screening, names, values):
        """Joint fits of one forward step: the ``top`` linear candidates by screening (one on a
        non-linear model, finished when its short fit pays) and every non-linear one (a short
        probe, finished when in reach, :func:`in_reach`). Returns {candidate: fit} and the candidates fitted."""
        chi2, wide = comparison.chi2, comparison.footing(cur) > 1
        linear = sorted((c for c in pool if not nonlinear(c)), key=lambda c: screening[c]["chi2"])[: 1 if wide else self.top]
        tried = linear + [c for c in pool if nonlinear(c)]
        margin, per_param = criterion(cur_band)

        def linear_fit(c):  # from the distributions where its screening was best
            budget = PROBE_NFEV if wide else None
            f = self.joint(screening[c]["theta"], names + [c], {**values, c: screening[c]["values"]}, max_nfev=budget)
            if budget and chi2(cur) - chi2(f) > margin + per_param * len(EFFECTS[c].parameters):
                f = self.joint(f.theta_, names + [c], fitted_values(f))
            return f

        fits = dict(zip(linear, self.map(linear_fit, linear)))
        others = [fits[k] for k in linear]
        self.reach_bar, self.unfinished, self._unfinished_of = reach_bar(comparison, cur, others), {}, (comparison, cur)
        # non-linear: a short joint fit, continued when it is in reach
        todo = {c: (names + [c], {**values, c: screening[c]["values"]}, others) for c in tried[len(linear):]}
        for c, (fits[c], stopped) in self._nonlinear_fits(comparison, cur, todo, self.reach_bar).items():
            if stopped:
                self.unfinished[c] = todo[c]
        return fits, tried

"""Forward selection of missing effects with joint refits, a pair step where two effects only
together close their share of the gap, the backward and size checks; each returns its steps as data.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from itertools import combinations
from types import SimpleNamespace
from typing import Any

import numpy as np

from ...vehicle.effects import EFFECTS, PHYSICAL, VANISHES
from .band import excess_rms
from .comparison import criterion
from .effectset import family_of, fitted_values, resolvable
from .fitter import nonlinear

__all__ = ["STEP_SHRINK", "PAIR_PARTNERS", "PAIR_POOL", "Step", "Forward", "Pruned", "admissible", "dynamic_pairs", "forward_selection",
           "backward_check", "comparison_margin", "indistinct", "size_check"]

#: An added effect that does not explain the rest of the gap must close at least this fraction of it (excess RMS after / before);
#: two effects added as a pair must close it twice over (STEP_SHRINK squared).
STEP_SHRINK = 0.75
#: Partners tried with a justified effect that alone closes less than a quarter (the next best by chi2).
PAIR_PARTNERS = 2
#: Non-linear candidates whose pairs are probed when a step stalls without a partner (:func:`dynamic_pairs`), and the probes' budget.
PAIR_POOL, PAIR_PROBE_NFEV = 4, 6


@dataclass(frozen=True)
class Step:
    """One effect added by the forward selection.

    Attributes
    ----------
    name : str
        Registry name.
    fit : StructureFit
        The joint fit with it (a pair's partner: the pair's).
    band, band_kind : NullBand, str
        The null band the fit is judged by and its kind (``own``, ``nonlinear_footing``).
    explains : bool
        The fit is inside that band.
    gap_after : float
        Excess RMS of z after it (:func:`.band.excess_rms`).
    ambiguous : list of str
        Families of the candidates within the tie margin of it.
    candidates, screening : dict
        chi2 on the linear footing of every candidate fitted at the step; the screening's
        [predicted chi2, held chi2, anchor] of every ranked candidate.
    pair : str or None
        The partner it was added with.
    """

    name: str
    fit: Any
    band: Any
    band_kind: str
    explains: bool
    gap_after: float
    ambiguous: list = field(default_factory=list)
    candidates: dict = field(default_factory=dict)
    screening: dict = field(default_factory=dict)
    pair: str | None = None


@dataclass(frozen=True)
class Forward:
    """The forward selection's outcome: the steps taken, the final fit and its band, the first
    step's joint fits and screening, and {candidate: why} of those passed over (with
    ``explains_gap``: the unresolvable candidate that explains the gap, which ends the search)."""

    steps: tuple
    final: Any
    band: Any
    fits: dict
    screening: dict
    unresolved: dict


@dataclass(frozen=True)
class Pruned:
    """The steps left after a check, the removed effects ({"effect", "registry_name", and
    "chi2_saved" or "size"}, all so far), the final fit and its band."""

    steps: tuple
    removed: tuple
    final: Any
    band: Any


def _refit_without(fitter, cur, start_effects, added, name, hopeless_above=None):
    """``cur`` refitted jointly without the added effect ``name`` (the others from their values in ``cur``;
    ``hopeless_above`` as :meth:`.fitter.CandidateFitter.joint`)."""
    values = fitted_values(cur)
    rest = list(start_effects) + [n for n in added if n != name]
    return fitter.joint(cur.theta_, rest, {k: values[k] for k in rest}, hopeless_above=hopeless_above)


def _removal_bar(comparison, fitter, cur, name, margin, per_param):
    """The chi2 (a callable of the refit's footing, :meth:`.comparison.ModelComparison.chi2_bar`)
    below which ``cur`` refitted without ``name`` loses it in :func:`backward_check`: ``cur``'s
    chi2 plus the effect's penalty and the margin between the two footings (a refit above it
    keeps the effect, whatever its exact chi2)."""
    def bar(wide: bool) -> float:
        refit = SimpleNamespace(scale_=fitter.data.scale_for(wide))  # the margin reads a fit's footing from its scale alone
        chi2 = comparison.chi2(cur) + per_param * len(EFFECTS[name].parameters) + comparison_margin(comparison, name, margin, refit, cur)
        return comparison.chi2_bar(chi2, wide)
    return bar


def admissible(comparison, data, name, fit) -> tuple[bool, str]:
    """Whether ``name``'s fitted size in ``fit`` can be named, and why not: resolvable at the
    data's sampling (:func:`.effectset.resolvable`; ``data`` gives the command ``delta`` and
    step ``dt``) and told from none at the sampling's interval
    (:func:`indistinct` with the null's inflation, as :func:`size_check` judges the final model:
    the baseline band's, the data's own noise; the non-linear footing's wider inflation holds the
    luck of the model's few realisations, which the chi2 comparison already judges, and on
    lateral_load_transfer_p030 widened the load sensitivity's interval to hold 0 where the fit
    lowered chi2 by three converted footing spreads).
    An addition of no size is the model it was added to: its chi2 gain is sampling luck (a
    non-linear candidate at zero size runs on its own few realisations)."""
    ok, why = resolvable(name, fitted_values(fit)[name], data.delta, data.dt)
    if not ok:
        return False, why
    weak = _no_size(comparison, name, fit)
    return weak is None, weak or ""


def _no_size(comparison, name, fit) -> str | None:
    """Why ``name``'s size in ``fit`` is not told from none at the data's noise (:func:`indistinct`), or None."""
    return indistinct(fit, comparison.band.inflation).get(name)


def _gain_justified(comparison, before, after, name, margin, per_param) -> bool:
    """The chi2 ``after`` saves against ``before`` beats the penalty of ``name``'s parameters plus the
    margin (widened where the two fits stand on different footings, :func:`comparison_margin`)."""
    return comparison.chi2(before) - comparison.chi2(after) - per_param * len(EFFECTS[name].parameters) > comparison_margin(comparison, name, margin, before, after)


def comparison_margin(comparison, name, margin, a, b) -> float:
    """The tie margin of fits ``a`` and ``b`` that differ by the effect ``name``: the non-linear
    footing's wide one (:meth:`.comparison.ModelComparison.margin`, the luck of its few germs), except
    for an effect held at its physical value (:data:`uqdrive.vehicle.effects.PHYSICAL`) between two
    non-linear fits: both run on the same raw germs (their scales differing only by the
    realisations each keeps from spinning), whose luck they share, and the effect has no parameter
    to fit it, so the data's margin (the baseline band's, the data's own noise) on that footing
    (times the larger squared scale ratio) judges it. ``margin``: the current band's (:func:`.comparison.criterion`)."""
    fa, fb = comparison.footing(a), comparison.footing(b)
    if name in PHYSICAL and fa > 1.0 and fb > 1.0:
        return criterion(comparison.band)[0] * max(fa, fb)
    return comparison.margin(margin, a, b)


def _step(comparison, name, fit, band, which, explains, gap, fits, screening, margin, pair=None) -> Step:
    chi2 = comparison.chi2
    tie = [c for c in fits if c != name and chi2(fits[c]) - chi2(fit) <= margin]
    named = {family_of(name)} | ({family_of(pair)} if pair is not None else set())  # a pair partner is named with it, no alternative
    return Step(name, fit, band, which, bool(explains), gap, ambiguous=sorted({family_of(c) for c in tie} - named),
                candidates={c: round(chi2(f), 2) for c, f in sorted(fits.items(), key=lambda kv: chi2(kv[1]))},
                screening={c: [round(v["chi2"], 2), round(v["held"], 2), v["anchor"]] for c, v in sorted(screening.items(), key=lambda kv: kv[1]["chi2"])
                           if np.isfinite(v["chi2"])}, pair=pair)


def _pair_holds(comparison, data, fits, a, b, pair, margin, per_param) -> bool:
    """Each member of the pair ``a``, ``b`` (joint fit ``pair``) saves more than its penalty plus the margin on top of the other, and has a size."""
    return (_gain_justified(comparison, fits[a], pair, b, margin, per_param) and _gain_justified(comparison, fits[b], pair, a, margin, per_param)
            and admissible(comparison, data, a, pair)[0] and admissible(comparison, data, b, pair)[0])


def _pair_steps(comparison, fits, screening, first, first_band, partner, pair, prev_gap, key, margin):
    """The two steps of a pair that holds (``first`` with its own fit, then ``partner`` with the
    pair's), or None when together they neither explain the rest nor close it by STEP_SHRINK squared."""
    band_2, which_2 = comparison.own_band(pair, key=key + 20)
    explains = band_2.max_statistic(pair.z_) <= band_2.threshold
    gap = excess_rms(pair.z_, band_2)
    if not (explains or gap <= STEP_SHRINK**2 * prev_gap):
        return None
    band_1, which_1 = first_band
    one = _step(comparison, first, fits[first], band_1, which_1, band_1.max_statistic(fits[first].z_) <= band_1.threshold,
                excess_rms(fits[first].z_, band_1), fits, screening, margin, pair=partner)
    two = _step(comparison, partner, pair, band_2, which_2, explains, gap, {**fits, partner: pair}, screening, margin, pair=first)
    return [one, two]


def pair_step(comparison, fitter, cur, cur_band, names, values, fits, screening, first, first_band, prev_gap, key):
    """Two effects that only together close their share: ``first`` (justified, resolvable, but
    closing less than a quarter alone) fitted jointly with each of the next :data:`PAIR_PARTNERS`
    justified, resolvable candidates of this step. A pair is taken when each member is justified
    on top of the other (chi2 saved beyond its penalty plus the margin), and together they explain
    the rest of the gap or close it by STEP_SHRINK squared (two additions' worth).

    ``first_band``: (band, kind) of ``first``'s own fit, as the forward step computed it.
    Returns the two steps (``first``, then its partner with the pair's fit), or None."""
    margin, per_param = criterion(cur_band)
    data, chi2 = fitter.data, comparison.chi2
    partners = [c for c in sorted(fits, key=lambda c: chi2(fits[c])) if c != first
                and _gain_justified(comparison, cur, fits[c], c, margin, per_param)
                and admissible(comparison, data, c, fits[c])[0]][:PAIR_PARTNERS]
    best = None
    for c in partners:
        start = {**values, **fitted_values(fits[first]), c: fitted_values(fits[c])[c]}
        pair = fitter.joint(fits[first].theta_, names + [first, c], start)
        if _pair_holds(comparison, data, fits, first, c, pair, margin, per_param) and (best is None or chi2(pair) < chi2(best[1])):
            best = (c, pair)
    if best is None:
        return None
    return _pair_steps(comparison, fits, screening, first, first_band, best[0], best[1], prev_gap, key, margin)


def dynamic_pairs(comparison, fitter, cur, cur_band, names, values, fits, screening, prev_gap, key):
    """Two dynamic effects that act against each other (a roll mode's lead and the tyres' lag on a
    chirp): alone, each bends its parameters to cancel the other and has no size; together they
    explain. When the step stalls and :func:`pair_step` finds no partner for its best addition,
    the pairs of the :data:`PAIR_POOL` non-linear candidates best by their own joint fits get a
    short joint fit (:data:`PAIR_PROBE_NFEV` evaluations) from the registry's start values, not
    from their bent single fits; the best is finished and taken under :func:`pair_step`'s rules.
    Returns the two steps (the member with the better own fit first), or None."""
    margin, per_param = criterion(cur_band)
    chi2 = comparison.chi2
    pool = sorted((c for c in fits if nonlinear(c)), key=lambda c: chi2(fits[c]))[:PAIR_POOL]
    couples = list(combinations(pool, 2))
    probes = dict(zip(couples, fitter.map(lambda ab: fitter.joint(cur.theta_, names + list(ab), {**values, **{e: list(EFFECTS[e].start) for e in ab}},
                                                                  max_nfev=PAIR_PROBE_NFEV), couples)))
    if not probes:
        return None
    a, b = min(probes, key=lambda k: chi2(probes[k]))
    pair = fitter.joint(probes[a, b].theta_, names + [a, b], fitted_values(probes[a, b]))
    if not _pair_holds(comparison, fitter.data, fits, a, b, pair, margin, per_param):
        return None
    return _pair_steps(comparison, fits, screening, a, comparison.own_band(fits[a], key=key), b, pair, prev_gap, key, margin)


def simplest_first(fits, chi2, margin) -> list:
    """The candidates of ``fits`` by chi2, except that of those tied with the best (within
    ``margin``, as :func:`_step` calls them ambiguous) the one with the fewest parameters leads:
    where the data cannot tell a general effect from a special case of it (the tyre's whole
    shape from its peak alone), the special case is named and the general one listed as
    ambiguous, not the other way round."""
    order = sorted(fits, key=lambda c: chi2(fits[c]))
    if not order:
        return order
    tied = [c for c in order if chi2(fits[c]) - chi2(fits[order[0]]) <= margin]
    lead = min(tied, key=lambda c: (len(EFFECTS[c].parameters), chi2(fits[c])))
    return [lead] + [c for c in order if c != lead]


def forward_selection(comparison, fitter, candidates, max_effects, base, band, start_effects, lap) -> Forward:
    """Add effects of ``candidates`` (at most ``max_effects``) to ``base`` (judged by ``band``) while each one is justified: its joint fit lowers chi2 by more than its
    penalty plus the null-calibrated margin, its size is resolvable and told from none
    (:func:`admissible`), and it
    explains the rest of the gap or closes at least a quarter of it (:data:`STEP_SHRINK`); when
    the best justified addition closes less, a partner may join it (:func:`pair_step`) or, with
    none, two non-linear candidates may be added together (:func:`dynamic_pairs`); stop when the
    model explains the data (inside its own band). ``lap(stage, detail)`` is told of every step."""
    cur, cur_band = base, band
    names, values = list(start_effects), dict(start_effects)
    steps, first_fits, first_screening, unresolved = [], {}, {}, {}
    chi2, data = comparison.chi2, fitter.data
    explained = False
    while not explained and len(steps) < max_effects:
        pool = [c for c in candidates if c not in names]
        if not pool:
            break
        screening = fitter.screen(cur, pool)
        fits, tried = fitter.fit_pool(comparison, cur, cur_band, pool, screening, names, values)
        step = len(steps)
        if step == 0:
            first_fits, first_screening = fits, screening
        lap(f"step_{step + 1}", f" (screened {len(pool)}, fitted {', '.join(tried)})")
        margin, per_param = criterion(cur_band)
        prev_gap = excess_rms(cur.z_, cur_band)
        best = min(fits, key=lambda c: chi2(fits[c]))
        if fitter.unfinished and chi2(fits[best]) + margin >= fitter.reach_bar:  # a stopped probe might tie with the best
            fits = fitter.finish(fits)
        while True:  # a probe stopped out of reach (fitter.unfinished) ranks where it stopped: finished where the choice reads it
            chosen, stalled, reached = None, None, False
            for c in simplest_first(fits, chi2, margin):
                if c in fitter.unfinished:
                    reached = True
                    break
                fc = fits[c]
                ok, why = resolvable(c, fitted_values(fc)[c], data.delta, data.dt)
                if not ok:
                    unresolved[c] = why
                    if step == 0 and c == best and (band.max_statistic(fc.z_) <= band.threshold or excess_rms(fc.z_, band) <= 0.5 * prev_gap):
                        unresolved["explains_gap"] = c  # the gap is at the sampling's resolution
                        return Forward(tuple(steps), cur, cur_band, first_fits, first_screening, unresolved)
                    continue
                weak = _no_size(comparison, c, fc)
                if weak:  # no size the sampling tells from none (the resolution was checked above)
                    unresolved[c] = weak
                    continue
                if not _gain_justified(comparison, cur, fc, c, margin, per_param):
                    break  # the best resolvable addition is not justified: nothing further is
                after_band, which = comparison.own_band(fc, key=step + 1)
                explains = after_band.max_statistic(fc.z_) <= after_band.threshold
                gap = excess_rms(fc.z_, after_band)
                if explains or gap <= STEP_SHRINK * prev_gap:
                    chosen = c
                else:
                    stalled = c
                break
            if not fitter.unfinished:
                break
            tie = chosen is not None and chi2(fits[chosen]) + margin >= fitter.reach_bar
            if not (reached or stalled is not None or tie):  # a stalled step seeks pairs among all fits
                break
            fits = fitter.finish(fits)
        if step == 0:
            first_fits = fits
        if chosen is not None:
            fc = fits[chosen]
            steps.append(_step(comparison, chosen, fc, after_band, which, explains, gap, fits, screening, margin))
            names.append(chosen)
            values = fitted_values(fc)
            cur, cur_band, explained = fc, after_band, explains
            continue
        if stalled is None or len(steps) + 2 > max_effects:
            break
        pair = pair_step(comparison, fitter, cur, cur_band, names, values, fits, screening, stalled, (after_band, which), prev_gap, key=step + 1)
        if pair is None:
            pair = dynamic_pairs(comparison, fitter, cur, cur_band, names, values, fits, screening, prev_gap, key=step + 1)
        if pair is None:
            break
        steps.extend(pair)
        names.extend([pair[0].name, pair[1].name])
        cur, cur_band, explained = pair[1].fit, pair[1].band, pair[1].explains
        values = fitted_values(cur)
    return Forward(tuple(steps), cur, cur_band, first_fits, first_screening, unresolved)


def backward_check(comparison, fitter, steps, cur, cur_band, start_effects, removed=()) -> Pruned:
    """Check every added effect of ``steps`` against its removal: refit ``cur`` without it; drop it when the
    chi2 it saves is within its penalty plus the null-calibrated margin. ``removed``: those removed before."""
    steps, removed = list(steps), list(removed)
    order, refits = [s.name for s in steps], {}
    for step in list(steps):
        added = [s.name for s in steps]
        if len(start_effects) + len(added) < 2:
            break
        margin, per_param = criterion(cur_band)
        if step.name not in refits:  # on workers: the refits of this and every later step from this cur at once (fitter.map)
            later = [n for n in order[order.index(step.name):] if n in added] if fitter.jobs > 1 else [step.name]
            refits = dict(zip(later, fitter.map(lambda name: _refit_without(
                fitter, cur, start_effects, added, name, _removal_bar(comparison, fitter, cur, name, margin, per_param)), later)))
        fit = refits.pop(step.name)
        saved = comparison.chi2(fit) - comparison.chi2(cur) - per_param * len(EFFECTS[step.name].parameters)
        if saved <= comparison_margin(comparison, step.name, margin, fit, cur):
            removed.append({"effect": family_of(step.name), "registry_name": step.name, "chi2_saved": round(saved, 2)})
            steps = [s for s in steps if s is not step]
            cur, refits = fit, {}
            cur_band, _ = comparison.own_band(fit, key=10 + len(removed))
    return Pruned(tuple(steps), tuple(removed), cur, cur_band)


def indistinct(fit, factor: float) -> dict:
    """The effects of ``fit`` whose size the data cannot tell from none: {registry name: reason}.

    An effect's magnitude parameter (:data:`uqdrive.vehicle.effects.VANISHES`) whose 95 % interval
    holds the value at which the effect vanishes. ``factor`` scales the Gauss-Newton covariance:
    the null's inflation (the sampling noise, as the chi2 test measures it)."""
    if fit.effect is None:
        return {}
    intervals = fit.effect_intervals(factor)
    out = {}
    for name in fit.effect.names:
        if name not in VANISHES:
            continue
        param, value = VANISHES[name]
        est, lo, hi = intervals[f"{name}.{param}"]
        if lo <= value <= hi:
            out[name] = f"{param} {est:.4g} [{lo:.4g}, {hi:.4g}] holds {value:g} (no effect)"
    return out


def size_check(comparison, fitter, steps, base, cur, cur_band, start_effects, removed=()) -> Pruned:
    """Drop the added effects whose size the sampling cannot tell from none (:func:`indistinct` at
    the final model, with the null's inflation), one at a time: of those, the one whose removal
    costs the least chi2 (refitting the rest without it; correlated effects widen each other's
    intervals, so their half-widths do not say which one the data need), until every named
    effect has a size; each removed is appended to ``removed`` with its reason. The final fit and
    band are ``base`` and the baseline's band when nothing is left."""
    steps, removed = list(steps), list(removed)
    while steps:
        # the sampling's interval, not the verdict's (widened by the lack of fit): a model far from
        # the data (a four-wheel car) would otherwise lose effects whose removal costs thousands
        added = [s.name for s in steps]
        weak = {k: v for k, v in indistinct(cur, comparison.band.inflation).items() if k in added}
        if not weak:
            break
        if len(added) == 1:
            name, refits = added[0], {added[0]: base}
        else:
            refits = dict(zip(weak, fitter.map(lambda k: _refit_without(fitter, cur, start_effects, added, k), list(weak))))
            name = min(weak, key=lambda k: comparison.chi2(refits[k]))
        removed.append({"effect": family_of(name), "registry_name": name, "size": weak[name]})
        steps = [s for s in steps if s.name != name]
        if not steps:
            return Pruned((), tuple(removed), base, comparison.band)
        cur = refits[name]
        cur_band, _ = comparison.own_band(cur, key=30 + len(removed))
    return Pruned(tuple(steps), tuple(removed), cur, cur_band)

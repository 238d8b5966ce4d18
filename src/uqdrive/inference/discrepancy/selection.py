"""Forward selection of missing effects with joint refits, a pair step where two effects only
together close their share of the gap, and the backward check of every added effect.
"""

from __future__ import annotations

from itertools import combinations

import numpy as np

from ...vehicle.effects import EFFECTS, PHYSICAL, VANISHES
from .band import excess_rms
from .effectset import family_of, fitted_values, resolvable
from .verdict import lack_of_fit

__all__ = ["STEP_SHRINK", "PARTIAL_SHARE", "PAIR_PARTNERS", "PAIR_POOL", "acceptance", "admissible", "comparison_margin", "departures", "dynamic_pairs",
           "forward_selection", "backward_check", "indistinct", "size_check"]

#: An added effect that does not explain the rest of the gap must close at least this fraction of it (excess RMS after / before);
#: two effects added as a pair must close it twice over (STEP_SHRINK squared).
STEP_SHRINK = 0.75
#: A named set that neither explains the gap nor halves it is kept as the partial truth, with ``unrecognised``
#: after it, when it closes at least this share of the chi2 excess over the null level (:func:`acceptance`).
PARTIAL_SHARE = 0.5
#: Partners tried with a justified effect that alone closes less than a quarter (the next best by chi2).
PAIR_PARTNERS = 2
#: Non-linear candidates whose pairs are probed when a step stalls without a partner (:func:`dynamic_pairs`), and the probes' budget.
PAIR_POOL, PAIR_PROBE_NFEV = 4, 6


def _refit_without(finder, ctx, cur, start_effects, added, name):
    """``cur`` refitted jointly without the added effect ``name`` (the others from their values in ``cur``)."""
    values = fitted_values(cur)
    rest = list(start_effects) + [n for n in added if n != name]
    return finder._joint(ctx, cur.theta_, rest, {k: values[k] for k in rest})


def admissible(finder, ctx, name, fit) -> tuple[bool, str]:
    """Whether ``name``'s fitted size in ``fit`` can be named, and why not: resolvable at the
    data's sampling (:func:`.effectset.resolvable`) and told from none at the sampling's interval
    (:func:`indistinct` with the null's inflation, as :func:`size_check` judges the final model:
    the baseline band's, the data's own noise; the non-linear footing's wider inflation holds the
    luck of the model's few realisations, which the chi2 comparison already judges, and on
    lateral_load_transfer_p030 widened the load sensitivity's interval to hold 0 where the fit
    lowered chi2 by three converted footing spreads).
    An addition of no size is the model it was added to: its chi2 gain is sampling luck (a
    non-linear candidate at zero size runs on its own few realisations)."""
    ok, why = resolvable(name, fitted_values(fit)[name], ctx.delta, ctx.dt)
    if not ok:
        return False, why
    weak = _no_size(finder, name, fit)
    return weak is None, weak or ""


def _no_size(finder, name, fit) -> str | None:
    """Why ``name``'s size in ``fit`` is not told from none at the data's noise (:func:`indistinct`), or None."""
    return indistinct(fit, finder.band_.inflation).get(name)


def _gain_justified(finder, before, after, name, margin, per_param) -> bool:
    """The chi2 ``after`` saves against ``before`` beats the penalty of ``name``'s parameters plus the
    margin (widened where the two fits stand on different footings, :func:`comparison_margin`)."""
    return finder._chi2(before) - finder._chi2(after) - per_param * len(EFFECTS[name].parameters) > comparison_margin(finder, name, margin, before, after)


def comparison_margin(finder, name, margin, a, b) -> float:
    """The tie margin of fits ``a`` and ``b`` that differ by the effect ``name``: the non-linear
    footing's wide one (:meth:`.finder.DiscrepancyFinder._margin`, the luck of its few germs), except
    for an effect held at its physical value (:data:`uqdrive.vehicle.effects.PHYSICAL`) between two
    non-linear fits: both run on the same raw germs (their scales differing only by the
    realisations each keeps from spinning), whose luck
    they share, and the effect has no parameter to fit it, so the data's margin (the baseline
    band's, the data's own noise) on that footing (times the larger squared scale ratio) judges it
    (the exact course angle on a saturating tyre saved 8 such margins, half a wide one).
    ``margin``: the current band's (:meth:`.finder.DiscrepancyFinder._criterion`)."""
    fa, fb = finder._footing(a), finder._footing(b)
    if name in PHYSICAL and fa > 1.0 and fb > 1.0:
        return finder._criterion(finder.band_)[0] * max(fa, fb)
    return finder._margin(margin, a, b)


def _step(finder, name, fit, band, which, explains, gap, fits, screening, margin, extra=None) -> dict:
    tie = [c for c in fits if c != name and finder._chi2(fits[c]) - finder._chi2(fit) <= margin]
    extra = extra or {}
    named = {family_of(name)} | ({family_of(extra["pair"])} if "pair" in extra else set())  # a pair partner is named with it, no alternative
    return {"name": name, "fit": fit, "band": band, "band_kind": which, "explains": bool(explains), "gap_after": gap,
            "ambiguous": sorted({family_of(c) for c in tie} - named),
            "candidates": {c: round(finder._chi2(f), 2) for c, f in sorted(fits.items(), key=lambda kv: finder._chi2(kv[1]))},
            "screening": {c: [round(v["chi2"], 2), round(v["held"], 2), v["anchor"]] for c, v in sorted(screening.items(), key=lambda kv: kv[1]["chi2"])
                          if np.isfinite(v["chi2"])}, **extra}


def _pair_holds(finder, ctx, fits, a, b, pair, margin, per_param) -> bool:
    """Each member of the pair ``a``, ``b`` (joint fit ``pair``) saves more than its penalty plus the margin on top of the other, and has a size."""
    return (_gain_justified(finder, fits[a], pair, b, margin, per_param) and _gain_justified(finder, fits[b], pair, a, margin, per_param)
            and admissible(finder, ctx, a, pair)[0] and admissible(finder, ctx, b, pair)[0])


def _pair_steps(finder, ctx, fits, screening, first, first_band, partner, pair, prev_gap, key, margin):
    """The two step records of a pair that holds (``first`` with its own fit, then ``partner`` with the
    pair's), or None when together they neither explain the rest nor close it by STEP_SHRINK squared."""
    band_2, which_2 = finder._own_band(ctx, partner, pair, finder.band_, key=key + 20)
    explains = band_2.max_statistic(pair.z_) <= band_2.threshold
    gap = excess_rms(pair.z_, band_2)
    if not (explains or gap <= STEP_SHRINK**2 * prev_gap):
        return None
    band_1, which_1 = first_band
    one = _step(finder, first, fits[first], band_1, which_1, band_1.max_statistic(fits[first].z_) <= band_1.threshold,
                excess_rms(fits[first].z_, band_1), fits, screening, margin, {"pair": partner})
    two = _step(finder, partner, pair, band_2, which_2, explains, gap, {**fits, partner: pair}, screening, margin, {"pair": first})
    return [one, two]


def pair_step(finder, ctx, cur, cur_band, names, values, fits, screening, first, first_band, prev_gap, key):
    """Two effects that only together close their share: ``first`` (justified, resolvable, but
    closing less than a quarter alone) fitted jointly with each of the next :data:`PAIR_PARTNERS`
    justified, resolvable candidates of this step. A pair is taken when each member is justified
    on top of the other (chi2 saved beyond its penalty plus the margin), and together they explain
    the rest of the gap or close it by STEP_SHRINK squared (two additions' worth).

    ``first_band``: (band, kind) of ``first``'s own fit, as the forward step computed it.
    Returns the two step records (``first``, then its partner with the pair's fit), or None."""
    margin, per_param = finder._criterion(cur_band)
    partners = [c for c in sorted(fits, key=lambda c: finder._chi2(fits[c])) if c != first
                and _gain_justified(finder, cur, fits[c], c, margin, per_param)
                and admissible(finder, ctx, c, fits[c])[0]][:PAIR_PARTNERS]
    best = None
    for c in partners:
        start = {**values, **fitted_values(fits[first]), c: fitted_values(fits[c])[c]}
        pair = finder._joint(ctx, fits[first].theta_, names + [first, c], start)
        if _pair_holds(finder, ctx, fits, first, c, pair, margin, per_param) and (best is None or finder._chi2(pair) < finder._chi2(best[1])):
            best = (c, pair)
    if best is None:
        return None
    return _pair_steps(finder, ctx, fits, screening, first, first_band, best[0], best[1], prev_gap, key, margin)


def dynamic_pairs(finder, ctx, cur, cur_band, names, values, fits, screening, prev_gap, key):
    """Two dynamic effects that act against each other (a roll mode's lead and the tyres' lag on a
    chirp): alone, each bends its parameters to cancel the other and has no size; together they
    explain. When the step stalls and :func:`pair_step` finds no partner for its best addition,
    the pairs of the :data:`PAIR_POOL` non-linear candidates best by their own joint fits get a
    short joint fit (:data:`PAIR_PROBE_NFEV` evaluations) from the registry's start values, not
    from their bent single fits; the best is finished and taken under :func:`pair_step`'s rules.
    Returns the two step records (the member with the better own fit first), or None."""
    margin, per_param = finder._criterion(cur_band)
    pool = sorted((c for c in fits if finder._nonlinear(c)), key=lambda c: finder._chi2(fits[c]))[:PAIR_POOL]
    probes = {(a, b): finder._joint(ctx, cur.theta_, names + [a, b], {**values, a: list(EFFECTS[a].start), b: list(EFFECTS[b].start)},
                                    max_nfev=PAIR_PROBE_NFEV) for a, b in combinations(pool, 2)}
    if not probes:
        return None
    a, b = min(probes, key=lambda k: finder._chi2(probes[k]))
    pair = finder._joint(ctx, probes[a, b].theta_, names + [a, b], fitted_values(probes[a, b]))
    if not _pair_holds(finder, ctx, fits, a, b, pair, margin, per_param):
        return None
    return _pair_steps(finder, ctx, fits, screening, a, finder._own_band(ctx, a, fits[a], finder.band_, key=key), b, pair, prev_gap, key, margin)


def forward_selection(finder, ctx, base, band, start_effects, lap):
    """Add effects while each one is justified: its joint fit lowers chi2 by more than its
    penalty plus the null-calibrated margin, its size is resolvable and told from none
    (:func:`admissible`), and it
    explains the rest of the gap or closes at least a quarter of it (:data:`STEP_SHRINK`); when
    the best justified addition closes less, a partner may join it (:func:`pair_step`) or, with
    none, two non-linear candidates may be added together (:func:`dynamic_pairs`); stop when the
    model explains the data (inside its own band). Returns the final fit and its band."""
    cur, cur_band = base, band
    names, values = list(start_effects), dict(start_effects)
    explained = False
    while not explained and len(finder.steps_) < finder.max_effects:
        pool = [c for c in finder.candidates_ if c not in names]
        if not pool:
            break
        screening = finder._screen(ctx, cur, pool)
        fits, tried = finder._fit_pool(ctx, cur, cur_band, pool, screening, names, values)
        step = len(finder.steps_)
        if step == 0:
            finder.fits_, finder.screening_ = fits, screening
        lap(f"step_{step + 1}", f" (screened {len(pool)}, fitted {', '.join(tried)})")
        margin, per_param = finder._criterion(cur_band)
        prev_gap = excess_rms(cur.z_, cur_band)
        chosen, stalled, best = None, None, min(fits, key=lambda c: finder._chi2(fits[c]))
        for c in sorted(fits, key=lambda c: finder._chi2(fits[c])):
            fc = fits[c]
            ok, why = resolvable(c, fitted_values(fc)[c], ctx.delta, ctx.dt)
            if not ok:
                finder.unresolved_[c] = why
                if step == 0 and c == best and (band.max_statistic(fc.z_) <= band.threshold or excess_rms(fc.z_, band) <= 0.5 * prev_gap):
                    finder.unresolved_["explains_gap"] = c  # the gap is at the sampling's resolution
                    return cur, cur_band
                continue
            weak = _no_size(finder, c, fc)
            if weak:  # no size the sampling tells from none (the resolution was checked above)
                finder.unresolved_[c] = weak
                continue
            if not _gain_justified(finder, cur, fc, c, margin, per_param):
                break  # the best resolvable addition is not justified: nothing further is
            after_band, which = finder._own_band(ctx, c, fc, band, key=step + 1)
            explains = after_band.max_statistic(fc.z_) <= after_band.threshold
            gap = excess_rms(fc.z_, after_band)
            if explains or gap <= STEP_SHRINK * prev_gap:
                chosen = c
            else:
                stalled = c
            break
        if chosen is not None:
            fc = fits[chosen]
            finder.steps_.append(_step(finder, chosen, fc, after_band, which, explains, gap, fits, screening, margin))
            names.append(chosen)
            values = fitted_values(fc)
            cur, cur_band, explained = fc, after_band, explains
            continue
        if stalled is None or len(finder.steps_) + 2 > finder.max_effects:
            break
        pair = pair_step(finder, ctx, cur, cur_band, names, values, fits, screening, stalled, (after_band, which), prev_gap, key=step + 1)
        if pair is None:
            pair = dynamic_pairs(finder, ctx, cur, cur_band, names, values, fits, screening, prev_gap, key=step + 1)
        if pair is None:
            break
        finder.steps_.extend(pair)
        names.extend([pair[0]["name"], pair[1]["name"]])
        cur, cur_band, explained = pair[1]["fit"], pair[1]["band"], pair[1]["explains"]
        values = fitted_values(cur)
    return cur, cur_band


def backward_check(finder, ctx, cur, cur_band, start_effects):
    """Check every added effect against its removal: refit without it; drop it when the
    chi2 it saves is within its penalty plus the null-calibrated margin."""
    for step in list(finder.steps_):
        added = [s["name"] for s in finder.steps_]
        if len(start_effects) + len(added) < 2:
            break
        fit = _refit_without(finder, ctx, cur, start_effects, added, step["name"])
        margin, per_param = finder._criterion(cur_band)
        saved = finder._chi2(fit) - finder._chi2(cur) - per_param * len(EFFECTS[step["name"]].parameters)
        if saved <= comparison_margin(finder, step["name"], margin, fit, cur):
            finder.removed_.append({"effect": family_of(step["name"]), "registry_name": step["name"], "chi2_saved": round(saved, 2)})
            finder.steps_.remove(step)
            cur = fit
            cur_band, _ = finder._own_band(ctx, step["name"], fit, finder.band_, key=10 + len(finder.removed_))
    return cur, cur_band


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


def size_check(finder, ctx, base, cur, cur_band, start_effects):
    """Drop the added effects whose size the sampling cannot tell from none (:func:`indistinct` at
    the final model, with the null's inflation), one at a time: of those, the one whose removal
    costs the least chi2 (refitting the rest without it; correlated effects widen each other's
    intervals, so their half-widths do not say which one the data need), until every named
    effect has a size; ``finder.removed_`` gets each with its reason. Returns the final fit and
    band (``base`` and the baseline's band when nothing is left)."""
    while finder.steps_:
        # the sampling's interval, not the verdict's (widened by the lack of fit): a model far from
        # the data (a four-wheel car) would otherwise lose effects whose removal costs thousands
        added = [s["name"] for s in finder.steps_]
        weak = {k: v for k, v in indistinct(cur, finder.band_.inflation).items() if k in added}
        if not weak:
            break
        if len(added) == 1:
            name, refits = added[0], {added[0]: base}
        else:
            refits = {k: _refit_without(finder, ctx, cur, start_effects, added, k) for k in weak}
            name = min(weak, key=lambda k: finder._chi2(refits[k]))
        finder.removed_.append({"effect": family_of(name), "registry_name": name, "size": weak[name]})
        finder.steps_ = [s for s in finder.steps_ if s["name"] != name]
        if not finder.steps_:
            return base, finder.band_
        cur = refits[name]
        cur_band, _ = finder._own_band(ctx, name, cur, finder.band_, key=30 + len(finder.removed_))
    return cur, cur_band


def acceptance(finder, base, band, final, final_band) -> dict:
    """Whether the named effects of ``final`` are kept, by which rule, and the numbers it read.

    Rules, in order: the final model ``explains`` the data (inside its own band); it ``halves``
    the gap (excess RMS of z, :func:`.band.excess_rms`); it is the ``partial`` truth: it closes
    at least :data:`PARTIAL_SHARE` of the chi2 excess over the null level,
    1 - (chi2_final - chi2_null) / (chi2_base - chi2_null) >= PARTIAL_SHARE (both chi2 on the
    linear footing, :meth:`.finder.DiscrepancyFinder._chi2`; chi2_null the baseline band's mean
    level), and the chi2 it saves beats the penalty of its parameters plus the null's margin;
    else ``rejected`` (nothing named: a small part of an unknown gap is no evidence for the
    effect). A partial set is named with ``unrecognised`` after it."""
    explains = bool(final_band.max_statistic(final.z_) <= final_band.threshold)
    gap0, gap1 = excess_rms(base.z_, band), excess_rms(final.z_, final_band)
    null = band.mean_square_null * base.z_.size
    before, after = finder._chi2(base) - null, finder._chi2(final) - null
    share = 1.0 - max(after, 0.0) / before if before > 0 else 0.0
    margin, per_param = finder._criterion(band)
    added = sum(len(EFFECTS[s["name"]].parameters) for s in finder.steps_)
    needed = per_param * added + finder._margin(margin, base, final)
    saved = finder._chi2(base) - finder._chi2(final)
    rule = ("explains" if explains else "halves" if gap1 <= 0.5 * gap0 else
            "partial" if share >= PARTIAL_SHARE and saved > needed else "rejected")
    return {"rule": rule, "share_closed": round(share, 4), "chi2_excess_before": round(before, 2), "chi2_excess_after": round(after, 2),
            "chi2_saved": round(saved, 2), "chi2_needed": round(needed, 2),
            "criterion": f"kept when the model explains the data, or halves the gap, or closes at least {PARTIAL_SHARE:g} of the chi2 "
                         "excess over the null level with a saving beyond its parameters' penalty plus 2 null sd (then named "
                         "with 'unrecognised' after it); else nothing is named"}


def departures(finder, ctx, final, band) -> dict:
    """What the data want of each named parameter held at its physical value
    (:data:`uqdrive.vehicle.effects.PHYSICAL`): the final model refitted with it free.

    A free k of the course angle bends to whatever rest of the gap reaches y; that departure is
    reported as the rest acting through the parameter, and the effect is judged at its value.
    Returns {registry name: {"parameter", "physical", "fitted": [estimate, lo95, hi95] (the
    verdict's scaling: null inflation x the free fit's lack of fit), "chi2_at_physical",
    "chi2_fitted", "chi2_saved", "chi2_needed", "holds_physical", "departs", "reading"}}."""
    names = list(final.effect.names) if final.effect is not None else []
    margin, per_param = finder._criterion(band)
    out = {}
    for name in (n for n in names if n in PHYSICAL):
        param, value = PHYSICAL[name]
        free = finder._joint(ctx, final.theta_, names, fitted_values(final), release=(name,))
        own = finder._band_of(free)
        est, lo, hi = free.effect_intervals(band.inflation * lack_of_fit(free.chi2_, free.z_.size, own.mean_square_null))[f"{name}.{param}"]
        saved, needed = finder._chi2(final) - finder._chi2(free), per_param + finder._margin(margin, final, free)
        holds, departs = bool(lo <= value <= hi), bool(saved > needed and not lo <= value <= hi)
        reading = (f"{param} fitted free is its physical {value:g} within the data's noise" if holds else
                   f"{param} fitted free departs from its physical {value:g}: the rest of the gap acting through it" if departs else
                   f"{param} fitted free misses its physical {value:g}, saving less chi2 than its penalty plus the null's margin")
        out[name] = {"parameter": param, "physical": value, "fitted": [round(float(v), 6) for v in (est, lo, hi)],
                     "chi2_at_physical": round(finder._chi2(final), 2), "chi2_fitted": round(finder._chi2(free), 2),
                     "chi2_saved": round(saved, 2), "chi2_needed": round(needed, 2), "holds_physical": holds, "departs": departs, "reading": reading}
    return out

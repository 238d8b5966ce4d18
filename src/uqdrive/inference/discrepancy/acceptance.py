"""Whether a named set of effects is kept, and what the data want of a parameter held at its
physical value: the two judgements of the final model after the selection.
"""

from __future__ import annotations

from ...vehicle.effects import EFFECTS, PHYSICAL
from .band import excess_rms
from .comparison import criterion
from .effectset import fitted_values
from .verdict import lack_of_fit

__all__ = ["PARTIAL_SHARE", "acceptance", "departures"]

#: A named set that neither explains the gap nor halves it is kept as the partial truth, with ``unrecognised``
#: after it, when it closes at least this share of the chi2 excess over the null level (:func:`acceptance`).
PARTIAL_SHARE = 0.5


def acceptance(comparison, names, base, band, final, final_band) -> dict:
    """Whether the named effects ``names`` of ``final`` are kept, by which rule, and the numbers it read.

    Rules, in order: the final model ``explains`` the data (inside its own band); it ``halves``
    the gap (excess RMS of z, :func:`.band.excess_rms`); it is the ``partial`` truth: it closes
    at least :data:`PARTIAL_SHARE` of the chi2 excess over the null level,
    1 - (chi2_final - chi2_null) / (chi2_base - chi2_null) >= PARTIAL_SHARE (both chi2 on the
    linear footing, :meth:`.comparison.ModelComparison.chi2`; chi2_null the baseline band's mean
    level), and the chi2 it saves beats the penalty of its parameters plus the null's margin;
    else ``rejected`` (nothing named: a small part of an unknown gap is no evidence for the
    effect). A partial set is named with ``unrecognised`` after it."""
    chi2 = comparison.chi2
    explains = bool(final_band.max_statistic(final.z_) <= final_band.threshold)
    gap0, gap1 = excess_rms(base.z_, band), excess_rms(final.z_, final_band)
    null = band.mean_square_null * base.z_.size
    before, after = chi2(base) - null, chi2(final) - null
    share = 1.0 - max(after, 0.0) / before if before > 0 else 0.0
    margin, per_param = criterion(band)
    added = sum(len(EFFECTS[name].parameters) for name in names)
    needed = per_param * added + comparison.margin(margin, base, final)
    saved = chi2(base) - chi2(final)
    rule = ("explains" if explains else "halves" if gap1 <= 0.5 * gap0 else
            "partial" if share >= PARTIAL_SHARE and saved > needed else "rejected")
    return {"rule": rule, "share_closed": round(share, 4), "chi2_excess_before": round(before, 2), "chi2_excess_after": round(after, 2),
            "chi2_saved": round(saved, 2), "chi2_needed": round(needed, 2),
            "criterion": f"kept when the model explains the data, or halves the gap, or closes at least {PARTIAL_SHARE:g} of the chi2 "
                         "excess over the null level with a saving beyond its parameters' penalty plus 2 null sd (then named "
                         "with 'unrecognised' after it); else nothing is named"}


def departures(comparison, fitter, final, band) -> dict:
    """What the data want of each named parameter held at its physical value
    (:data:`uqdrive.vehicle.effects.PHYSICAL`): the final model refitted with it free.

    A free k of the course angle bends to whatever rest of the gap reaches y; that departure is
    reported as the rest acting through the parameter, and the effect is judged at its value.
    Returns {registry name: {"parameter", "physical", "fitted": [estimate, lo95, hi95] (the
    verdict's scaling: null inflation x the free fit's lack of fit), "chi2_at_physical",
    "chi2_fitted", "chi2_saved", "chi2_needed", "holds_physical", "departs", "reading"}}."""
    names = list(final.effect.names) if final.effect is not None else []
    margin, per_param = criterion(band)
    chi2 = comparison.chi2
    out = {}
    for name in (n for n in names if n in PHYSICAL):
        param, value = PHYSICAL[name]
        free = fitter.joint(final.theta_, names, fitted_values(final), release=(name,))
        own = comparison.band_of(free)
        est, lo, hi = free.effect_intervals(band.inflation * lack_of_fit(free.chi2_, free.z_.size, own.mean_square_null))[f"{name}.{param}"]
        saved, needed = chi2(final) - chi2(free), per_param + comparison.margin(margin, final, free)
        holds, departs = bool(lo <= value <= hi), bool(saved > needed and not lo <= value <= hi)
        reading = (f"{param} fitted free is its physical {value:g} within the data's noise" if holds else
                   f"{param} fitted free departs from its physical {value:g}: the rest of the gap acting through it" if departs else
                   f"{param} fitted free misses its physical {value:g}, saving less chi2 than its penalty plus the null's margin")
        out[name] = {"parameter": param, "physical": value, "fitted": [round(float(v), 6) for v in (est, lo, hi)],
                     "chi2_at_physical": round(chi2(final), 2), "chi2_fitted": round(chi2(free), 2),
                     "chi2_saved": round(saved, 2), "chi2_needed": round(needed, 2), "holds_physical": holds, "departs": departs, "reading": reading}
    return out

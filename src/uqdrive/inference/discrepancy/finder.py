"""The discrepancy workflow: fit the best baseline, calibrate a null band by parametric bootstrap,
localise where the data leave it, name the missing effect among registered candidates (or say
``none`` / ``unrecognised``), add it to the model and measure how much of the gap it closes.
"""

from __future__ import annotations

import time as _time
from dataclasses import replace
from typing import Any, Callable, Mapping, NamedTuple, Sequence

import numpy as np

from ...numerics.threads import single_blas_thread
from ...rng import rng_stream
from ...settings import Settings
from ...vehicle.augmented import THETA_NAMES, AugmentedSimulator
from ...vehicle.effects import EFFECTS, ModelStructure, expand_names
from .data import prepare_measured, speed_profile
from .band import bootstrap_band, moment_statistics, statistic_scale
from .effectset import EffectSet, family_of, fitted_values, testable
from .fit import SimulationMemo, StructureFit
from .posterior import AugmentedPosterior
from .ranking import screen
from .selection import acceptance, backward_check, departures, forward_selection, size_check
from .separate import suggest_input
from .verdict import assemble_verdict, model_document

__all__ = ["DEFAULT_CANDIDATES", "family_of", "DiscrepancyFinder"]

#: A non-linear candidate is first fitted with this budget of model evaluations (:meth:`DiscrepancyFinder._probe`), then finished only
#: when it closed PROBE_SHARE of what the best linear candidate closed (its chi2 can only fall further).
PROBE_NFEV, PROBE_SHARE = 6, 0.25

DEFAULT_CANDIDATES = ("tyre_saturation", "actuator_lag", "actuator_delay", "road_bank", "wind_gust", "lateral_kinematics", "sensor_bias", "sensor_scale")


class _Context(NamedTuple):
    """What every fit of one dataset shares: simulator, compared times, noise, spin threshold, runs used, command (rad), step (s)."""

    sim: Any; index: np.ndarray; noise: np.ndarray; spin: float | None; n: int; delta: np.ndarray; dt: float  # noqa: E702


class DiscrepancyFinder:
    """Find, localise, name and repair what a single-track model misses in measured data.

    Parameters
    ----------
    settings : Settings
        The car's constants, the load and gust distributions (fixed), the prior of mu, l_f and
        the mean wind (start of the baseline fit), the spin policy, and the discrepancy search's
        settings (``settings.discover``), which the arguments below override.
    candidates : sequence of str, optional
        Registry names or families (``sensor_bias``) of the candidate effects.
    model_samples : int
        Realisations of the linear models (common random numbers).
    nonlinear_samples : int
        Realisations of models that need numerical integration (tyre saturation).
    bootstrap : int
        Null replicates for the calibration of the scan statistic.
    level : float
        Family-wise false-alarm rate of the localisation.
    max_times : int
        Time points compared (evenly spaced, t = 0 left out).
    top : int
        Linear candidates re-identified jointly with the distributions after screening, at every
        step of the forward selection (non-linear candidates are always fitted jointly).
    max_effects : int
        Effects added at most (forward selection stops earlier when the model explains the data
        or no addition is justified).
    start_model : mapping, optional
        A ``model.yaml`` document (``effects``, ``distributions``) to start from: its effects are
        refitted jointly with the distributions and further effects added on top.
    seed : int, optional
        Root seed of the model germs and the bootstrap (default: the settings' ``seed``).
    posterior : bool, optional
        Sample the emcee posterior of the augmented model (:class:`.posterior.AugmentedPosterior`)
        into the verdict's ``posterior``; default: :meth:`uqdrive.settings.Discover.wants_posterior`
        (enabled, for the named effects in its ``posterior_effects``; empty: whatever is named). True
        forces it for every verdict.
    inputs : mapping of str to ndarray, optional
        Steering commands (rad, on the measured time grid) among which the verdict's
        ``separating_input`` names, for every candidate ambiguous with the named one, the input
        that would separate them best (:func:`.separate.suggest_input`); the measured input is
        always among them. None: no suggestion.
    log : callable, optional
        Receives one progress line per finished stage (baseline fit, null band, screening,
        joint fits, verdict, posterior) with its seconds, e.g. ``print`` to a log file.

    The data may carry any channels of :data:`uqdrive.vehicle.channels.CHANNELS` and a speed ``v``
    that changes: model, null band and fits compare exactly those channels along that speed.

    Attributes
    ----------
    verdict_ : dict
        The ``verdict.json`` content.
    baseline_, augmented_ : StructureFit
        The start model (the baseline, or ``start_model`` refitted) and the final one with every
        added effect (its ``effect`` an :class:`.effectset.EffectSet`).
    band_, augmented_band_ : NullBand
        The null bands of ``baseline_`` and ``augmented_``.
    steps_ : list of dict
        The effects added, in order (name, joint fit, band, gap after, ambiguity).
    measured_, scale_ : ndarray, shape (2, C, K)
        Over the measured channels ``channels_`` (tuple of str).
    candidates_, untestable_ : list
        The candidates the data can test; {"effect", "reason"} of those they cannot.
    time_ : ndarray, shape (K,)
    fits_ : dict
        Joint fit per re-identified candidate of the first step.
    acceptance_, departures_ : dict
        Why the named set was kept or rejected (:func:`.selection.acceptance`); per named effect
        held at its physical value, the departure its free refit wants (:func:`.selection.departures`).
    posterior_ : AugmentedPosterior or None
        The posterior of ``augmented_``'s parameters when it was sampled.
    """

    def __init__(self, settings: Settings, candidates: Sequence[str] | None = None, model_samples: int | None = None,
                 nonlinear_samples: int | None = None, bootstrap: int | None = None, level: float | None = None,
                 max_times: int | None = None, top: int | None = None, seed: int | None = None, posterior: bool | None = None,
                 inputs: Mapping[str, Any] | None = None, log: Callable[[str], None] | None = None, max_effects: int | None = None,
                 start_model: Mapping[str, Any] | None = None):
        d = settings.discover
        self.settings = settings
        default = DEFAULT_CANDIDATES if d.candidates is None else list(d.candidates)
        self.candidates = expand_names(candidates if candidates is not None else default)
        self.model_samples = int(model_samples or d.model_samples)
        self.nonlinear_samples = int(nonlinear_samples or d.nonlinear_samples)
        self.bootstrap = int(bootstrap or d.bootstrap)
        self.level = float(level or d.level)
        self.max_times = int(max_times or d.max_times)
        self.top = int(top or d.top)
        self.max_effects = int(max_effects or d.max_effects)
        self.start_model = start_model
        self.seed = int(settings.seed if seed is None else seed)
        self.posterior = posterior
        self.inputs = inputs
        self.log = log

    # -- data ---------------------------------------------------------------------------------
    def _prepare(self, ds):
        """The measured data on the compared grid (:func:`.data.prepare_measured`)."""
        m = prepare_measured(ds, self.settings.spin, self.max_times)
        self.channels_, self.stride_, self.spun_, self.samples_used_ = m.channels, m.stride, m.spun, m.samples_used
        return m.x, m.index, m.noise, m.spin

    # -- workflow -----------------------------------------------------------------------------
    def fit(self, ds) -> "DiscrepancyFinder":
        """Run the workflow on an ensemble dataset in the uqdrive data schema."""
        with single_blas_thread():
            return self._fit(ds)

    def _start(self):
        """Distribution start (the prior, or the start model's) and the start model's effects."""
        if self.start_model is not None:
            d = self.start_model["distributions"]
            theta0 = [d["mu"]["mean"], d["mu"]["std"], d["l_f"]["mean"], d["l_f"]["std"], d["F_w_mean"]["low"], d["F_w_mean"]["high"]]
            effects = {k: [float(v[p]) for p in EFFECTS[k].parameters] for k, v in (self.start_model.get("effects") or {}).items()}
            return theta0, effects
        return list(self.settings.layout.start), {}

    def _fit(self, ds) -> "DiscrepancyFinder":
        clock = _time.perf_counter()
        x, index, noise, spin = self._prepare(ds)
        n = x.shape[1]
        t = np.asarray(ds["time"].values, float)
        delta = np.asarray(ds["delta"].values, float)
        self.interpolation_ = str(ds["delta"].attrs.get("interpolation", "linear"))
        speed = speed_profile(ds)
        v_c = float(ds.attrs["v_c"]) if speed is None else float(np.mean(speed))
        self.speed_profile_ = None if speed is None else {"min": float(speed.min()), "max": float(speed.max()), "mean": v_c}
        self.candidates_, self.untestable_ = testable(self.candidates, self.channels_)
        raw = AugmentedSimulator.drawn(self.settings, t, delta, v_c, self.model_samples, rng_stream(self.seed, "discrepancy_model"),
                                       stride=self.stride_, interpolation=self.interpolation_,
                                       channels=self.channels_, speed=speed)
        self._raw_germs = raw.germs
        sim = raw.with_germs(raw.germs.matched())  # linear models: moment-matched germs (Germs.matched)
        self.time_ = sim.output_time[index]
        self.noise_variance_ = noise
        ratio = n / self.model_samples
        self.measured_ = moment_statistics(x, index)
        self.scale_ = statistic_scale(x, index, model_ratio=ratio)
        theta0, start_effects = self._start()
        stages = {}

        def lap(stage, detail=""):
            stages[stage] = _time.perf_counter() - clock - sum(stages.values())
            if self.log is not None:
                self.log(f"discover: {stage} done in {stages[stage]:.1f} s{detail}")

        ctx = _Context(sim, index, noise, spin, n, delta, float(t[1] - t[0]))
        self._n = n
        self._memo = SimulationMemo()  # the linear simulations the fits of this dataset share
        if start_effects:
            base = self._joint(ctx, theta0, list(start_effects), start_effects)
        else:
            base = StructureFit(sim, index, noise, spin, fixed=dict(self.settings.layout.known), memo=self._memo).fit(self.measured_, self.scale_, theta0)
        lap("baseline", f" ({n} realisations, {index.size} times, {self.model_samples} model realisations)")
        self.baseline_ = base
        self.band_ = band = self._null_band(ctx, base, key=0)
        self.footing_band_ = self._footing_band(ctx, base) if any(self._nonlinear(c) for c in self.candidates_ + list(start_effects)) else None
        stat0 = band.max_statistic(base.z_)
        significant = band.gate(base.z_)
        lap("null_band", f" ({self.bootstrap} replicates; max statistic {stat0:.3g}, threshold {band.threshold:.3g})")
        self.fits_, self.screening_, self.steps_, self.removed_, self.unresolved_, self.rejected_ = {}, {}, [], [], {}, []
        self.acceptance_, self.departures_ = {}, {}
        final, final_band = base, band
        if significant:
            final, final_band = self._forward(ctx, base, band, start_effects, lap)
            if len(self.steps_) > 1:
                final, final_band = self._backward(ctx, final, final_band, start_effects)
                lap("backward", f" ({len(self.removed_)} removed)")
            final, final_band = size_check(self, ctx, base, final, final_band, start_effects)
            self.acceptance_ = acceptance(self, base, band, final, final_band) if self.steps_ else {}
            if self.acceptance_.get("rule") == "rejected":  # too small a part of an unknown gap to trust
                self.rejected_, self.steps_ = [s["name"] for s in self.steps_], []
                final, final_band = base, band
            self.departures_ = departures(self, ctx, final, band) if self.steps_ else {}
        self.augmented_, self.augmented_band_ = final, final_band
        self.verdict_ = self._decide(base, band, stat0, significant, ctx)
        self.verdict_["separating_input"] = self._separating_input(delta, n)
        if self.log is not None:
            self.log(f"discover: verdict {[e['effect'] for e in self.verdict_['effects']] or self.verdict_['effect']}, "
                     f"gap {self.verdict_['gap_before']:.3g} -> {self.verdict_['gap_after']:.3g}")
        self._memo = None  # the fits are done: the posterior batches its own simulations
        self.posterior_ = None
        if self.steps_ and self._wants_posterior(self.verdict_["effect"]):
            self.posterior_ = AugmentedPosterior(**self.settings.discover.posterior).fit(self.augmented_, x, rng_stream(self.seed, "discrepancy_posterior"))
            self.verdict_["posterior"] = self.posterior_.summary()
            lap("posterior")
        self.verdict_["evidence"]["seconds"] = round(_time.perf_counter() - clock, 1)
        self.verdict_["evidence"]["stage_seconds"] = {k: round(v, 1) for k, v in stages.items()}
        return self

    # -- forward selection and backward check --------------------------------------------------
    def _criterion(self, band):
        """Null-calibrated tie margin (2 null sd of chi2) and penalty per parameter (2 x inflation)."""
        return 2.0 * band.chi2_null_sd, 2.0 * band.inflation

    def _chi2(self, fit) -> float:
        """chi2 of a fit on the common footing of the linear models' scale.

        A numerically integrated model runs on fewer realisations, so its z are divided by a
        wider scale (:meth:`_scale_for`): its chi2 then shrinks the systematic misfit by that
        factor squared and would favour it against every linear model. Its excess over the null
        level is converted back: null level + excess x (scale ratio)^2. A chi2 below the null
        level has no systematic part to convert: it stays as it is (scaled, the sampling luck of
        the few realisations would count ratio^2 times and favour every non-linear candidate
        where the gap is small; seen: chassis candidates of zero size 40 below the linear model
        on the same physics).

        The ratio is that of the scale the fit was judged with (``fit.scale_``), not of its final
        structure: a non-linear candidate fitted to zero size has a linear structure but its z
        on the wide scale (seen: a load transfer at h = 0 scored 2100 below the linear baseline
        it equals and won a forward step). Its null level is the non-linear footing's
        (:meth:`_footing_band`: the few raw realisations' own sampling included)."""
        ratio2 = self._footing(fit)
        level = self.band_.mean_square_null * fit.z_.size
        if ratio2 == 1.0:
            return fit.chi2_
        own = self._band_of(fit).mean_square_null * fit.z_.size
        return level + (fit.chi2_ - own) * (ratio2 if fit.chi2_ > own else 1.0)

    def _footing(self, fit) -> float:
        """Mean squared ratio of the scale ``fit`` was judged with to the linear models' (1: a linear model's footing)."""
        return float(np.mean((np.asarray(fit.scale_, float) / self.scale_) ** 2))

    def _band_of(self, fit):
        """The null band a fit's z are judged by: the baseline's, or the non-linear footing's."""
        return self.band_ if self._footing(fit) == 1.0 else (getattr(self, "footing_band_", None) or self.band_)

    def _margin(self, margin: float, *fits) -> float:
        """The tie margin of a comparison of ``fits`` in chi2 on the linear footing: a fit on the
        non-linear footing brings that footing's chi2 spread, converted by its squared scale
        ratio (its few raw realisations' luck, which moment-matched germs do not share)."""
        wide = [f for f in fits if self._footing(f) > 1.0]
        return max([margin] + [2.0 * self._footing(f) * self._band_of(f).chi2_null_sd for f in wide])

    def _forward(self, ctx, base, band, start_effects, lap):
        """Forward selection (:func:`.selection.forward_selection`): the final fit and its band."""
        return forward_selection(self, ctx, base, band, start_effects, lap)

    def _fit_pool(self, ctx, cur, cur_band, pool, screening, names, values):
        """Joint fits of one forward step: the ``top`` linear candidates by screening (one on a
        non-linear model, finished when its short fit pays) and every non-linear one (a short
        probe, finished when in reach). Returns {candidate: fit} and the candidates fitted."""
        linear = sorted((c for c in pool if not self._nonlinear(c)), key=lambda c: screening[c]["chi2"])[: 1 if self._footing(cur) > 1 else self.top]
        tried = linear + [c for c in pool if self._nonlinear(c)]
        fits, (margin, per_param) = {}, self._criterion(cur_band)
        for c in linear:  # each from the distributions where its screening was best
            budget = PROBE_NFEV if self._footing(cur) > 1 else None
            fits[c] = self._joint(ctx, screening[c]["theta"], names + [c], {**values, c: screening[c]["values"]}, max_nfev=budget)
            if budget and self._chi2(cur) - self._chi2(fits[c]) > margin + per_param * len(EFFECTS[c].parameters):
                fits[c] = self._joint(ctx, fits[c].theta_, names + [c], fitted_values(fits[c]))
        for c in tried[len(linear):]:  # non-linear: a short joint fit, continued when it is in reach
            short = self._probe(ctx, cur.theta_, names + [c], {**values, c: screening[c]["values"]})
            if self._in_reach(cur, short, [fits[k] for k in linear]):
                short = self._joint(ctx, short.theta_, names + [c], fitted_values(short))
            fits[c] = short
        return fits, tried

    def _backward(self, ctx, cur, cur_band, start_effects):
        """Backward check (:func:`.selection.backward_check`)."""
        return backward_check(self, ctx, cur, cur_band, start_effects)

    def _separating_input(self, delta, n):
        """Per candidate ambiguous with the first named one: the input that tells them apart best."""
        chosen = self.verdict_["evidence"]["registry_name"]
        ambiguous = set(self.verdict_["ambiguous_with"])
        pairs = [(chosen, c) for c in self.fits_ if c != chosen and family_of(c) in ambiguous]
        if not (pairs and self.inputs):
            return []
        return suggest_input(self.fits_, pairs, {"measured": delta, **dict(self.inputs)}, n)

    def _wants_posterior(self, effect: str) -> bool:
        if self.posterior is not None:
            return bool(self.posterior)
        return self.settings.discover.wants_posterior(effect)

    def _null_band(self, ctx, base, key: int = 0):
        """Bootstrap replicates of the fitted ``base`` (the baseline, or a model with named
        effects) with the data's sample count and noise, each refitted to first order
        (:func:`.band.refit_projection`); ``key`` tells the bootstraps' random streams apart."""
        rng = rng_stream(self.seed, "discrepancy_bootstrap", *((key,) if key else ()))
        return bootstrap_band(ctx.sim, base, ctx.n, ctx.index, ctx.noise, ctx.spin, ctx.n / self.model_samples, rng, self.bootstrap, self.level)

    def _footing_band(self, ctx, base):
        """The null band of the non-linear footing: bootstrap replicates of ``base`` as
        :meth:`_null_band`, each compared with ``base``'s model on ``nonlinear_samples`` fresh raw
        germs (the linear model's sampling standing in for the non-linear model's), on the wide
        scale. A non-linear model runs on one such set of germs, whose luck a band without it
        counts as misfit (seen: the roll steer at its true size left a rest of 0.58 on
        discover's germs, 0 to 0.67 on three other sets)."""
        m, n_modes = self.nonlinear_samples, ctx.sim.germs.kle.shape[1]

        def model(rng):
            germs = type(ctx.sim.germs).draw(rng, m, n_modes)
            return StructureFit(ctx.sim.with_germs(germs), ctx.index, ctx.noise, ctx.spin).statistics(base.theta_, base.structure_)

        unit = (np.asarray(base.scale_, float) / self._scale_for(True, ctx.n)).ravel()
        rng = rng_stream(self.seed, "discrepancy_bootstrap", 99)
        return bootstrap_band(ctx.sim, base, ctx.n, ctx.index, ctx.noise, ctx.spin, ctx.n / m, rng, self.bootstrap, self.level,
                              model_statistics=model, jacobian=base.jacobian_ * unit[:, None])

    def _scale_for(self, nonlinear: bool, n):
        """The null-band scale for a model: a non-linear one uses fewer realisations."""
        if not nonlinear:
            return self.scale_
        return self.scale_ * np.sqrt((1 + n / self.nonlinear_samples) / (1 + n / self.model_samples))

    def _nonlinear(self, name):
        return EFFECTS[name].augment(ModelStructure(), EFFECTS[name].start).nonlinear

    def _sim_for(self, sim, nonlinear: bool):
        """The model's simulator. A model that needs numerical integration runs on the first
        ``nonlinear_samples`` germs as drawn, not moment-matched: the Magic-Formula ensemble's
        statistics are ruled by its few realisations near loss of control, which matching a
        small set does not fix but moves across the spin threshold (seen: a 150-germ matched
        set turned one excluded realisation into a kept one and multiplied beta's std misfit)."""
        return sim.with_germs(self._raw_germs.head(self.nonlinear_samples)) if nonlinear else sim

    def _screen(self, ctx, cur, pool):
        """Rank the candidates by the prediction of their joint fit (:func:`.ranking.screen`), held at ``cur``'s distributions
        and at the start's (the prior or the start model's, the one estimate no misfit has bent), a non-linear tyre linearised."""
        start = np.asarray(self._start()[0], float)
        anchors = {"current": np.asarray(cur.theta_, float), **({} if np.allclose(start, cur.theta_, rtol=1e-9, atol=1e-12) else {"start": start})}
        base = replace(cur.structure_, tyre="linear")  # a non-linear tyre's linearisation: a cheap ranking

        def held(name, theta):
            structure = EFFECTS[name].augment(base, EFFECTS[name].start)
            f = StructureFit(self._sim_for(ctx.sim, structure.nonlinear), ctx.index, ctx.noise, ctx.spin, effect=EFFECTS[name], base=base,
                             fit_theta=False, max_nfev=40, memo=getattr(self, "_memo", None))
            return f.fit(self.measured_, self._scale_for(structure.nonlinear, ctx.n), theta)

        fixed = {c: [self.settings.vehicle.E] if c == "tyre_saturation" else list(EFFECTS[c].start) for c in pool if self._nonlinear(c)}
        return screen(cur, pool, anchors, held, fixed)

    def _probe(self, ctx, theta, names, values):
        """Short joint fit (:data:`PROBE_NFEV`) from ``theta`` and from the prior's distributions, the better one: a linear
        baseline lowers mu to mimic saturation, a poor basin for a saturating tyre (the thesis' NLST data: chi2 5x the baseline's)."""
        return min((self._joint(ctx, th, names, values, max_nfev=PROBE_NFEV) for th in (theta, self._start()[0])), key=self._chi2)

    def _in_reach(self, cur, probe, others) -> bool:
        """Whether a non-linear candidate's short fit is worth finishing: it already closed at
        least :data:`PROBE_SHARE` of what the best linear candidate closed (a full fit only
        lowers chi2 further), or no linear candidate closed anything."""
        gain = self._chi2(cur) - min((self._chi2(f) for f in others), default=self._chi2(cur))
        return gain <= 0 or self._chi2(cur) - self._chi2(probe) >= PROBE_SHARE * gain

    def _joint(self, ctx, theta_start, names, values, max_nfev: int | None = None, release=()):
        """Distributions and the parameters of every effect in ``names`` fitted jointly; a parameter
        with one physical value is held there (:meth:`.effectset.EffectSet.physical`) unless its effect is in ``release``."""
        eff = EffectSet(names, {k: values[k] for k in names if k in values})
        held = {len(THETA_NAMES) + i: v for i, v in eff.physical(release).items()}
        # the footing follows the names, not the start values: a non-linear effect that starts
        # at zero size (refitted after its fit went there) may grow during the fit
        nonlinear = any(self._nonlinear(k) for k in names)
        budget = max_nfev or (25 if nonlinear else 60)
        f = StructureFit(self._sim_for(ctx.sim, nonlinear), ctx.index, ctx.noise, ctx.spin, effect=eff, max_nfev=budget,
                         fixed={**dict(self.settings.layout.known), **held}, memo=getattr(self, "_memo", None))
        return f.fit(self.measured_, self._scale_for(nonlinear, ctx.n), theta_start)

    # -- verdict ------------------------------------------------------------------------------
    def _own_band(self, ctx, name, fit, band, key: int = 1):
        """The null band of a model with named effects: its own bootstrap (a stronger gust or a
        sensor gain changes the spread the band normalises by); a non-linear model takes the
        non-linear footing's (the baseline's model on fresh raw germs, :meth:`_footing_band`:
        its own bootstrap, B x n realisations by RK4, would cost minutes)."""
        if self._footing(fit) > 1:
            return self._band_of(fit), "nonlinear_footing"
        return self._null_band(ctx, fit, key=key), "own"

    def _decide(self, base, band, stat0, significant, ctx):
        return assemble_verdict(self, base, band, stat0, significant, ctx)

    def model_document(self) -> dict:
        """The augmented model as ``model.yaml`` content (:func:`.verdict.model_document`)."""
        return model_document(self.augmented_, self.settings, self.verdict_)

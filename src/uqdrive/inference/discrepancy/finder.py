"""The discrepancy workflow: fit the best baseline, calibrate a null band by parametric bootstrap,
localise where the data leave it, name the missing effect among registered candidates (or say
``none`` / ``unrecognised``), add it to the model and measure how much of the gap it closes.
"""

from __future__ import annotations

import time as _time
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from ...numerics.backend import resolve_device
from ...numerics.threads import single_blas_thread
from ...rng import rng_stream
from ...settings import Settings
from ...settings.run import model_realisations
from ...vehicle.augmented import AugmentedSimulator
from ...vehicle.effects import EFFECTS, expand_names
from .acceptance import acceptance, departures
from .band import moment_statistics, statistic_scale
from .comparison import Compared, ModelComparison, NullBands, prepare_measured, speed_profile
from .effectset import family_of, testable
from .fitter import CandidateFitter, SimulationMemo, nonlinear
from ..parallel import resolve_jobs
from .posterior import AugmentedPosterior
from .selection import backward_check, forward_selection, size_check
from .separate import separating_inputs
from .verdict import assemble_verdict, model_document

__all__ = ["DEFAULT_CANDIDATES", "family_of", "DiscrepancyFinder"]

DEFAULT_CANDIDATES = ("tyre_saturation", "actuator_lag", "actuator_delay", "road_bank", "wind_gust", "lateral_kinematics", "sensor_bias", "sensor_scale")


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
        Realisations of the linear models (common random numbers); their cap when the settings'
        ``model_ratio`` sizes them to the file's runs (:func:`uqdrive.settings.run.model_realisations`).
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
    jobs : int or "auto"
        Worker processes for the independent fits of each search step (the candidates of a
        step, the refits of the backward check) and for the posterior (its batches of full-model
        evaluations, its emcee ensembles); the verdict is the same for every count
        (:mod:`uqdrive.inference.parallel`). ``"auto"``: the CPUs this process may use.
    device : {"cpu", "gpu", "auto"}
        Who integrates the non-linear models (:func:`uqdrive.numerics.backend.resolve_device`): the
        CPU path, or JAX on a GPU (:mod:`uqdrive.vehicle.accelerated.chassis_ensemble`, the same numbers to
        1e-10; the fits then run in this process, ``jobs`` 1: a forked worker cannot use the GPU).

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
    steps_ : tuple of Step
        The effects added, in order (:class:`.selection.Step`: name, joint fit, band, gap after, ambiguity).
    removed_ : list of dict
        The effects the backward and size checks removed, with the reason.
    comparison_ : ModelComparison
        How the fits were compared (chi2 on the linear footing, margins, bands).
    fitter_ : CandidateFitter
        The fits of the dataset (the baseline, joint fits, probes, screening).
    measured_, scale_ : ndarray, shape (2, C, K)
        Over the measured channels ``channels_`` (tuple of str).
    candidates_, untestable_ : list
        The candidates the data can test; {"effect", "reason"} of those they cannot.
    time_ : ndarray, shape (K,)
    model_samples_ : int
        The linear models' realisations used.
    fits_ : dict
        Joint fit per re-identified candidate of the first step.
    acceptance_, departures_ : dict
        Why the named set was kept or rejected (:func:`.acceptance.acceptance`); per named effect
        held at its physical value, the departure its free refit wants (:func:`.acceptance.departures`).
    posterior_ : AugmentedPosterior or None
        The posterior of ``augmented_``'s parameters when it was sampled.
    """

    def __init__(self, settings: Settings, candidates: Sequence[str] | None = None, model_samples: int | None = None,
                 nonlinear_samples: int | None = None, bootstrap: int | None = None, level: float | None = None,
                 max_times: int | None = None, top: int | None = None, seed: int | None = None, posterior: bool | None = None,
                 inputs: Mapping[str, Any] | None = None, log: Callable[[str], None] | None = None, max_effects: int | None = None,
                 start_model: Mapping[str, Any] | None = None, jobs: int | str = 1, device: str = "cpu"):
        d = settings.discover
        self.device, self.backend = device, resolve_device(device)
        self.jobs = 1 if self.backend == "jax" else resolve_jobs(jobs)
        self.settings = settings
        default = DEFAULT_CANDIDATES if d.candidates is None else list(d.candidates)
        self.candidates = expand_names(candidates if candidates is not None else default)
        self.model_samples = int(model_samples or d.model_samples)
        self.nonlinear_samples = int(nonlinear_samples or d.nonlinear_samples)
        self.model_ratio = float(d.model_ratio)
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
        """The measured data on the compared grid (:func:`.comparison.prepare_measured`)."""
        m = prepare_measured(ds, self.settings.spin, self.max_times)
        self.channels_, self.stride_, self.spun_, self.samples_used_ = m.channels, m.stride, m.spun, m.samples_used
        return m.x, m.index, m.noise, m.spin

    def _start(self):
        """Distribution start (the prior, or the start model's) and the start model's effects."""
        if self.start_model is not None:
            d = self.start_model["distributions"]
            theta0 = [d["mu"]["mean"], d["mu"]["std"], d["l_f"]["mean"], d["l_f"]["std"], d["F_w_mean"]["low"], d["F_w_mean"]["high"]]
            effects = {k: [float(v[p]) for p in EFFECTS[k].parameters] for k, v in (self.start_model.get("effects") or {}).items()}
            return theta0, effects
        return list(self.settings.layout.start), {}

    # -- workflow -----------------------------------------------------------------------------
    def fit(self, ds) -> "DiscrepancyFinder":
        """Run the workflow on an ensemble dataset in the uqdrive data schema."""
        with single_blas_thread():
            return self._fit(ds)

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
        m = self.model_samples_ = model_realisations(n, self.model_samples, self.nonlinear_samples, self.model_ratio)
        raw = AugmentedSimulator.drawn(self.settings, t, delta, v_c, m, rng_stream(self.seed, "discrepancy_model"),
                                       stride=self.stride_, interpolation=self.interpolation_,
                                       channels=self.channels_, speed=speed, backend=self.backend)
        sim = raw.with_germs(raw.germs.matched())  # linear models: moment-matched germs (Germs.matched)
        self.time_ = sim.output_time[index]
        self.noise_variance_ = noise
        self.measured_ = moment_statistics(x, index)
        self.scale_ = statistic_scale(x, index, model_ratio=n / m)
        data = Compared(sim, raw.germs, index, noise, spin, n, delta, float(t[1] - t[0]), self.measured_, self.scale_,
                        m, self.nonlinear_samples)
        theta0, start_effects = self._start()
        stages = {}

        def lap(stage, detail=""):
            stages[stage] = _time.perf_counter() - clock - sum(stages.values())
            if self.log is not None:
                self.log(f"discover: {stage} done in {stages[stage]:.1f} s{detail}")

        # the linear simulations the fits of this dataset share
        fitter = self.fitter_ = CandidateFitter(data, self.settings.layout.known, theta0, self.settings.vehicle.E, self.top, SimulationMemo(),
                                                   self.jobs)
        base = fitter.joint(theta0, list(start_effects), start_effects) if start_effects else fitter.baseline(theta0)
        lap("baseline", f" ({n} realisations, {index.size} times, {m} model realisations)")
        self.baseline_ = base
        bands = NullBands(data, self.seed, self.bootstrap, self.level)
        self.band_ = band = bands.null(base, key=0)
        stat0 = band.max_statistic(base.z_)
        significant = band.gate(base.z_)
        # the non-linear footing's band is bootstrapped where a non-linear model is judged: the
        # start model's, or candidates searched because the baseline left the null
        compared = list(start_effects) + (self.candidates_ if significant else [])
        self.footing_band_ = bands.footing(base) if any(nonlinear(c) for c in compared) else None
        comparison = self.comparison_ = ModelComparison(band, self.scale_, self.footing_band_, bands)
        fitter.resolve_at(band)
        lap("null_band", f" ({self.bootstrap} replicates; max statistic {stat0:.3g}, threshold {band.threshold:.3g})")
        self.fits_, self.screening_, self.steps_, self.removed_, self.unresolved_, self.rejected_ = {}, {}, (), [], {}, []
        self.acceptance_, self.departures_ = {}, {}
        final, final_band = base, band
        if significant:
            forward = forward_selection(comparison, fitter, self.candidates_, self.max_effects, base, band, start_effects, lap)
            self.steps_, self.fits_, self.screening_, self.unresolved_ = forward.steps, forward.fits, forward.screening, forward.unresolved
            final, final_band = forward.final, forward.band
            if len(self.steps_) > 1:
                checked = backward_check(comparison, fitter, self.steps_, final, final_band, start_effects)
                self.steps_, self.removed_, final, final_band = checked.steps, list(checked.removed), checked.final, checked.band
                lap("backward", f" ({len(self.removed_)} removed)")
            sized = size_check(comparison, fitter, self.steps_, base, final, final_band, start_effects, self.removed_)
            self.steps_, self.removed_, final, final_band = sized.steps, list(sized.removed), sized.final, sized.band
            self.acceptance_ = acceptance(comparison, [s.name for s in self.steps_], base, band, final, final_band) if self.steps_ else {}
            if self.acceptance_.get("rule") == "rejected":  # too small a part of an unknown gap to trust
                self.rejected_, self.steps_ = [s.name for s in self.steps_], ()
                final, final_band = base, band
            self.departures_ = departures(comparison, fitter, final, band) if self.steps_ else {}
        self.augmented_, self.augmented_band_ = final, final_band
        self.verdict_ = assemble_verdict(self, base, band, stat0, significant, data)
        self.verdict_["evidence"].update(model_samples=m, model_ratio=self.model_ratio)
        self.verdict_["separating_input"] = separating_inputs(self.fits_, self.verdict_["evidence"]["registry_name"], self.verdict_["ambiguous_with"],
                                                             self.inputs, delta, n)
        if self.log is not None:
            self.log(f"discover: verdict {[e['effect'] for e in self.verdict_['effects']] or self.verdict_['effect']}, "
                     f"gap {self.verdict_['gap_before']:.3g} -> {self.verdict_['gap_after']:.3g}")
        fitter.release()  # the fits are done: the posterior batches its own simulations
        self.posterior_ = None
        if self.steps_ and self._wants_posterior(self.verdict_["effect"]):
            self.posterior_ = AugmentedPosterior(**self.settings.discover.posterior, jobs=self.jobs).fit(self.augmented_, x, rng_stream(self.seed, "discrepancy_posterior"))
            self.verdict_["posterior"] = self.posterior_.summary()
            lap("posterior")
        self.verdict_["evidence"]["seconds"] = round(_time.perf_counter() - clock, 1)
        self.verdict_["evidence"]["stage_seconds"] = {k: round(v, 1) for k, v in stages.items()}
        return self

    def _wants_posterior(self, effect: str) -> bool:
        if self.posterior is not None:
            return bool(self.posterior)
        return self.settings.discover.wants_posterior(effect)

    def model_document(self) -> dict:
        """The augmented model as ``model.yaml`` content (:func:`.verdict.model_document`)."""
        return model_document(self.augmented_, self.settings, self.verdict_)

"""``uqdrive identify``: fit the Table 5.4 model to any ensemble in the uqdrive schema and write
``estimate.json`` and a fitted-vs-measured figure; every input problem is a clear error.

Realisations that lost control are found from the data (|beta| above the config's
``montecarlo.spin_threshold`` at any time, the criterion of simulated ensembles), whether or not
the file carries a ``spun`` flag, and the config's spin policy applies to them. A fit that ends
at a bound of its box or returns its starting point is reported as not converged, with warnings.
Outputs appear only once the fit is done: the output folder is created then, and anything this
run created is removed again on a failure or an interruption.
"""

from __future__ import annotations

import json
import math
import warnings
from pathlib import Path
from typing import Any, Callable, Mapping

import numpy as np

from ..io import DataError, atomic_path, check_run_count, check_spread, data_speed, present_channels, read_ensemble, speed_profile
from ..inference.identify import DistributionEstimator, WeightContext, state_weights
from ..vehicle.channels import ChannelChaosModel
from ..vehicle.chaos import DISTRIBUTIONS, LSTChaosModel
from ..vehicle.montecarlo import spin_mask
from ..vehicle.noise import estimate_noise_variance
from ..vehicle.statistics import ensemble_statistics, kl_divergence_series, used_samples
from ..vehicle.single_track import STATES
from ..settings import Settings, Spin, TimeGrid

__all__ = ["identify_file", "identify_dataset", "fit_status", "fit_warnings", "fit_notes", "write_outputs"]

UNCERTAIN = ("mu", "l_f", "F_w_mean")
#: Below this many runs the sampling error of the runs' own distribution is named in the estimate's notes.
FEW_RUNS = 100


def _model_settings(config: Mapping[str, Any], ds, source: str) -> Settings:
    """The settings of ``config`` on the measured grid and at the measured speed (the model runs on the data's time grid)."""
    t = ds["time"].values.astype(float)
    if abs(t[0]) > 1e-9:
        raise DataError(f"{source}: 'time' starts at {t[0]:g} s; the model starts from straight driving at t = 0: "
                        "subtract the start time from the time coordinate")
    dt = float(t[1] - t[0])
    v, _ = data_speed(ds)  # a profile's: its start (the settings' constant speed; the profile goes beside it)
    v = float(np.ravel(ds["v"].values)[0]) if v is None else v
    return Settings.from_config(config, time=TimeGrid(float(t[-1]), dt, dt), speed=v)


def _dst_divergence(settings: Settings, delta):
    """D_KL(NLST || LST) of the synthetic reality under the measured input (DST weights)."""
    from ..vehicle.montecarlo import STEERS, simulate_ensemble
    from ..vehicle.single_track import steering_input

    st = settings.steering
    for steer, sign in STEERS.items():
        if np.allclose(delta, steering_input(np.arange(delta.size) * settings.time.dt, st.delta_max, st.period, sign), atol=1e-6):
            stats = {m: ensemble_statistics(simulate_ensemble(settings, m, steer), settings.spin.policy) for m in ("lst", "nlst")}
            return kl_divergence_series(stats["nlst"], stats["lst"]).values
    raise DataError("the DST cost needs the synthetic reality (LST and NLST) under the same input; "
                    "the measured delta is neither the config's slalom nor its inverted form: use --cost std or inp")


def _lost_control(ds, spin: Spin, source: str):
    """Spin flags from the data, the file's own flags (or None) and the dataset carrying the former."""
    threshold = float(spin.threshold)
    if "beta" not in ds:  # no side slip recorded: lost control cannot be told from the data
        in_file = ds["spun"].values.astype(bool) if "spun" in ds else None
        spun = np.zeros(ds.sizes["sample"], bool) if in_file is None else in_file
        ds = ds.assign(spun=("sample", spun.astype(np.int8), {"units": "1", "long_name": "lost control, from the file's flags"}))
        mask = used_samples(ds, spin.policy)
        check_spread(ds, source, mask)
        return ds, spun, None
    spun = spin_mask(ds["beta"].values, threshold)
    in_file = ds["spun"].values.astype(bool) if "spun" in ds else None
    ds = ds.assign(spun=("sample", spun.astype(np.int8), {"units": "1", "long_name": f"lost control (|beta| > {threshold} rad), from the data"}))
    mask = used_samples(ds, spin.policy)
    if mask.sum() < 2:
        raise DataError(f"{source}: only {int(mask.sum())} of {mask.size} realisations kept control (|beta| <= {threshold:g} rad); "
                        "mean and std need at least 2: give more realisations or set montecarlo.spin_policy: keep in the config")
    check_spread(ds, source, mask)
    return ds, spun, in_file


#: What to check when the model does not fit (the misfit is beyond the sampling noise).
MISFIT_FIX = ("the model does not fit these data: if the vehicle constants are not this car's, check mass (vehicle file: "
              "mass in kg; config: vehicle.m_base), yaw inertia (yaw_inertia in kg m^2; vehicle.J0), cornering stiffness "
              "(cornering_stiffness in N/rad per axle, not kN/rad, or magic_formula; vehicle.c_Sf, c_Sr), wheelbase and "
              "speed; else check the units of the states, --m-load, and whether an effect the model lacks is present "
              "(uqdrive discover)")


def _words(name: str) -> str:
    """A parameter's name in the user's words: mu_mean -> "mu mean", F_w_mean_low -> "F_w_mean low"."""
    head, _, tail = name.rpartition("_")
    return f"{head} {tail}"


def fit_warnings(theta, theta0, bounds, names, converged: bool, message: str, standard_errors=None, reference=None, cost=None,
                 n_runs=None, start_results=None) -> list[str]:
    """Why a fit is not to be trusted, each with its likely fix: the optimiser's own verdict, an
    estimate on a bound of the box (a std at its lower bound excepted: that is the answer "no
    spread", see :func:`fit_notes`), standard errors that are not finite, a misfit beyond its
    reference distribution under the fitted model (``reference``, a
    :class:`uqdrive.inference.sampling.MisfitReference`, and the ``cost``), starts that end at
    different estimates with equally good misfits, or the starting point returned unchanged."""
    out = [] if converged else [f"the optimiser stopped without converging: {message}"]
    theta, theta0 = np.asarray(theta, float), np.asarray(theta0, float)
    if not np.all(np.isfinite(theta)):
        return out + ["the estimate is not finite"]
    lo, hi = np.array(bounds, float).T
    tol = 1e-6 * (hi - lo)
    for name, value, a, b, eps in zip(names, theta, lo, hi, tol):
        if name.endswith("_std") and value <= a + eps:
            continue
        if value <= a + eps or value >= b - eps:
            end, bound = ("lower", a) if value <= a + eps else ("upper", b)
            out.append(f"{name} = {value:.6g} ended at the bound {bound:g} of its search box: {_words(name)} is at the {end} bound "
                       f"{bound:g} of the search [{a:g}, {b:g}], so the data lie outside what the model reaches; {MISFIT_FIX}")
    if standard_errors is not None:
        se = np.asarray(standard_errors, float)
        std_at_zero = [n.endswith("_std") and v <= a + e for n, v, a, e in zip(names, theta, lo, tol)]
        bad = [n for n, e, z in zip(names, se, std_at_zero) if not z and not np.isfinite(e)]
        if bad:
            out.append(f"the standard errors of {', '.join(_words(n) for n in bad)} are not finite: these data do not determine "
                       "them (another parameter changes the moments in the same way); use a richer manoeuvre or declare a "
                       "quantity known (std: 0 in the config's uncertainty section)")
    if reference is not None and cost is not None and np.isfinite(reference.threshold) and cost > reference.threshold:
        out.append(f"the misfit is {cost / reference.expected:.3g} times the noise (cost {cost:.4g} against {reference.expected:.4g} "
                   f"expected from the sampling error of {n_runs} realisations; {reference.level:.0%} threshold {reference.threshold:.4g}, "
                   f"{reference.threshold / reference.expected:.3g} times the noise): {MISFIT_FIX}")
    if start_results and standard_errors is not None and reference is not None and np.isfinite(reference.expected):
        se = np.asarray(standard_errors, float)
        for th, c, ok in start_results:
            if not ok or c > cost + reference.expected:
                continue  # a worse local optimum (or a stop short of one): the best one was taken
            gap = np.abs(np.asarray(th) - theta) / se
            if np.any(np.isfinite(gap) & (gap > 3.0)):
                i = int(np.nanargmax(np.where(np.isfinite(gap), gap, -np.inf)))
                out.append(f"starts disagree: another start ends with an equally good misfit at {_words(names[i])} {th[i]:.6g} instead "
                           f"of {theta[i]:.6g} ({gap[i]:.3g} standard errors apart): the data do not single out one answer; use a "
                           "richer manoeuvre or declare a quantity known")
                break
    if np.all(np.abs(theta - theta0) <= 1e-10 * np.maximum(np.abs(theta0), 1.0)):
        out.append("the fit returned its starting point unchanged: the cost does not respond to the parameters (check the data)")
    return out


def fit_notes(names, theta, bounds, upper_bounds) -> list[str]:
    """Facts about a sound fit worth saying: a std estimated at zero (the lower bound of its
    search) is the answer "this quantity shows no spread", with a one-sided interval."""
    out = []
    lo, hi = np.array(bounds, float).T
    for name, value, a, b in zip(names, theta, lo, hi):
        if name.endswith("_std") and value <= a + 1e-6 * (b - a):
            u = upper_bounds.get(name)
            quantity = name[: -len("_std")]
            out.append(f"{quantity} std is estimated at zero (the lower end {a:g} of its search): the data show no spread of {quantity}"
                       + (f"; one-sided 95 % upper bound {u:.4g}" if u is not None and math.isfinite(u) else "")
                       + f". If {quantity} is known, declare it with uncertainty.{quantity}.std: 0")
    return out


def _channel_notes(settings: Settings, ds, channels, speed) -> list[str]:
    """What the recorded channels cannot answer: parameters they cannot separate, lost control
    without beta, unit conversions, runs at different speeds."""
    from ..inference.identifiability import unidentifiable_parameters

    # the four states identify every parameter fitted here (thesis sec. 5.3.1): the test is for subsets
    open_ = {} if channels == STATES else unidentifiable_parameters(settings, channels, UNCERTAIN)
    out = [f"{p} cannot be identified from the channels {', '.join(channels)} (observability rank test): its estimate is "
           f"not determined by the data; record {hint}" for p, hint in open_.items()]
    if "beta" not in channels:
        out.append("without beta, lost control cannot be detected from the data: every run is used (drop spun runs before)")
    if ds.attrs.get("conversions"):
        out.append(str(ds.attrs["conversions"]))
    if speed is not None and ds["v"].ndim == 2 and np.ptp(ds["v"].values, axis=0).max() > 0.01 * float(speed.min()):
        out.append("the runs' speed profiles differ by more than 1 %: the model follows their mean profile")
    return out


def _sampling_errors(theta, n: int) -> dict:
    """Sampling errors of the normal parameters' mean and std from n runs, std / sqrt(n) and
    std / sqrt(2 (n - 1)): how far the runs' own distribution is from the population's."""
    out = {}
    for i, k in enumerate(UNCERTAIN):
        if k == "F_w_mean":  # uniform: its interval, not a mean and std
            continue
        sd = abs(float(theta[2 * i + 1]))
        out[k] = [_finite(sd / math.sqrt(n)), _finite(sd / math.sqrt(2 * max(n - 1, 1)))]
    return out


def _finite(x):
    """JSON-safe number: non-finite values become null."""
    x = float(x)
    return x if math.isfinite(x) else None


def identify_file(config: Mapping[str, Any], measured: Path, cost: str, m_load: float | None, starts: int, out: Path,
                  state_scale: str | None = None, overwrite: bool = True) -> dict:
    """Identify from the ensemble file ``measured``; write ``out/estimate.json`` and ``out/fit.png``.

    ``state_scale`` (None: the config's ``identification.state_scale``) selects the per-state
    residual scale of (5.25), see :data:`uqdrive.inference.identify.STATE_SCALES`. ``out`` is
    created only after the fit; with ``overwrite=False`` existing outputs are refused.
    The summary reports ``n_spun`` and ``spun_indices`` (0-based positions along ``sample``)
    of the realisations that lost control according to the data, and ``spun_in_file_indices``
    when the file carries its own ``spun`` flag.
    """
    summary, draw = identify_dataset(config, read_ensemble(measured), str(measured), cost, m_load, starts, state_scale)
    write_outputs(Path(out), summary, draw, overwrite)
    return summary


def identify_dataset(config: Mapping[str, Any], ds, source: str, cost: str = "std", m_load: float | None = None, starts: int = 0,
                     state_scale: str | None = None) -> tuple[dict, Callable]:
    """Identify from the validated ensemble ``ds`` (named ``source`` in messages and in the
    summary's ``measured``): the estimate.json fields and ``draw(path=None)``, which draws fit.png
    (saved to ``path``, or returned as a matplotlib Figure when ``path`` is None)."""
    check_run_count(ds.sizes["sample"], source, "identify")
    channels = present_channels(ds)
    speed = speed_profile(ds)
    if cost == "dst" and (channels != STATES or speed is not None):
        raise DataError(f"{source}: the DST cost compares the LST and NLST states at constant speed; this file has channels "
                        f"{', '.join(channels)}{' and a changing speed' if speed is not None else ''}: use --cost std or inp")
    settings = _model_settings(config, ds, source)
    policy = settings.spin.policy
    ds, spun, in_file = _lost_control(ds, settings.spin, source)
    stats = ensemble_statistics(ds, policy, channels)
    ident = settings.identify
    scale = state_scale or ident.scale()
    try:
        state_weights(scale, stats["mean"].values, stats["std"].values)
    except ValueError:
        raise DataError(f"{source}: a state's measured {'mean' if scale == 'rms_mean' else 'std'} is zero throughout, so "
                        f"--state-scale {scale} cannot scale it; use --state-scale none") from None
    delta = ds["delta"].values
    m_load = float(settings.uncertainty.m_load.mean if m_load is None else m_load)
    model = LSTChaosModel(settings, uncertain=UNCERTAIN, time_variant_wind=False, order=ident.order,
                          quadrature_points=ident.quadrature_points, fixed={"m_load": m_load}, delta=delta)
    if channels != STATES or speed is not None:
        model = ChannelChaosModel(model, channels, speed)
    kl = _dst_divergence(settings, delta) if cost == "dst" else None
    theta0 = settings.uncertainty.theta(UNCERTAIN)
    runs = np.stack([ds[s].values[used_samples(ds, policy)] for s in channels]).astype(float)
    # Measurement noise inflates the measured std: the model's variance gets the noise variance
    # estimated from the data (order-4 differences leave the smooth signal out).
    noise = np.array([estimate_noise_variance(runs[i], order=4) for i in range(runs.shape[0])])
    est = DistributionEstimator(model, cost, starts=starts, rng=np.random.default_rng(settings.seed), max_iter=ident.max_iter,
                                wheelbase=settings.vehicle.wheelbase, state_scale=scale, optimiser=ident.optimiser,
                                noise_variance=noise)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            est.fit(stats["mean"].values, stats["std"].values, theta0, WeightContext(delta, kl), runs=runs)
        except ValueError as exc:  # the model cannot be evaluated at the config's start for these data
            raise DataError(f"{source}: the model cannot follow these data from the config's starting values ({exc}); "
                            "check v_c, the units of the states and the config's uncertainty means") from None
    summary = _summary(est, model, theta0, m_load, runs.shape[1])
    summary["warnings"] += [m for m in dict.fromkeys(str(w.message) for w in caught) if not m.startswith("identification did not converge")]
    summary["warnings"] += _channel_notes(settings, ds, channels, speed)
    n_used = int(stats.attrs["n_used"])
    sampling = _sampling_errors([v for u in UNCERTAIN for v in summary[u]], n_used)
    se_mu = summary["standard_errors"]["mu"][0]
    if n_used < FEW_RUNS and sampling["mu"][0] is not None and se_mu is not None and se_mu < sampling["mu"][0] / 3:
        summary["notes"].append(f"with {n_used} runs the runs' own mean of mu is uncertain by about {sampling['mu'][0]:.2g} "
                                f"(std / sqrt(n)), more than the fit's standard error {se_mu:.2g}: read mu's mean as "
                                f"+- {sampling['mu'][0]:.2g} (sampling_errors)")
    flagged = None if in_file is None else np.flatnonzero(in_file).tolist()
    if flagged is not None and flagged != np.flatnonzero(spun).tolist():
        summary["warnings"].append(f"the file's 'spun' flags ({len(flagged)}) disagree with the data criterion |beta| > "
                                   f"{settings.spin.threshold:g} rad ({int(spun.sum())}); the data criterion was used")
    summary.update({
        "cost_function": cost,
        "state_scale": scale,
        "m_load": m_load,
        "noise_variance": {state: float(v) for state, v in zip(channels, noise)},
        "sampling_errors": sampling,
        "channels": list(channels),
        "speed": "constant" if speed is None else f"profile {float(speed.min()):.4g}-{float(speed.max()):.4g} m/s",
        "samples": int(ds.sizes["sample"]),
        "samples_used": int(stats.attrs["n_used"]),
        "spin_policy": policy,
        "spin_threshold": float(settings.spin.threshold),
        "n_spun": int(spun.sum()),
        "spun_indices": np.flatnonzero(spun).tolist(),
        "measured": source,
    })
    if flagged is not None:
        summary["spun_in_file_indices"] = flagged
    moments, status = est.moments_, fit_status(summary)
    return summary, lambda path=None: _figure(stats, moments, path, status)


def fit_status(summary: Mapping[str, Any]) -> str:
    """A fit's status in words: whether the optimiser converged and whether the model fits (the
    misfit test), for the summary line and the title of fit.png."""
    fits = {True: "model fits", False: "model does not fit", None: "misfit not tested"}[summary.get("model_fits")]
    return f"{'optimiser converged' if summary['optimiser_converged'] else 'optimiser did not converge'}, {fits}"


def _summary(est: DistributionEstimator, model: LSTChaosModel, theta0, m_load: float, n_runs: int) -> dict:
    """The estimate.json fields of a fit: the distributions (known ones at their values), their
    standard errors and 95 % intervals, the goodness of fit, ``converged`` and the warnings."""
    names, th, err = model.theta_names, est.theta_, est.theta_std_
    ref = est.misfit_reference_
    notes = fit_warnings(th, theta0, est.bounds, names, est.converged_, est.message_, standard_errors=err, reference=ref,
                         cost=est.cost_, n_runs=n_runs, start_results=est.start_results_)
    value = dict(zip(names, th.tolist()))
    se = dict(zip(names, err.tolist()))
    fixed = {"m_load": m_load, **model.known}
    pairs = {u: ("mean", "std") if DISTRIBUTIONS[u] == "normal" else ("low", "high") for u in UNCERTAIN}
    out = {}
    for u, (a, b) in pairs.items():
        if u in model.known:
            out[u] = [model.known[u], 0.0] if b == "std" else [model.known[u], model.known[u]]
        else:
            out[u] = [_finite(value[f"{u}_{a}"]), _finite(value[f"{u}_{b}"])]
    intervals = {}
    for n in names:
        if n in est.upper_bounds_:
            intervals[n] = [0.0, _finite(est.upper_bounds_[n])]
        elif math.isfinite(se[n]):
            intervals[n] = [_finite(value[n] - 1.959963984540054 * se[n]), _finite(value[n] + 1.959963984540054 * se[n])]
        else:
            intervals[n] = [None, None]
    gof = None
    if ref is not None:
        gof = {"misfit": _finite(est.cost_), "expected": _finite(ref.expected), "ratio": _finite(est.cost_ / ref.expected),
               "threshold": _finite(ref.threshold), "level": ref.level, "p_value": _finite(ref.p_value(est.cost_)), "dof": _finite(ref.dof),
               "passed": bool(est.cost_ <= ref.threshold)}
    return {
        **out,
        "cost": _finite(est.cost_),
        "converged": bool(est.converged_) and not notes,
        "optimiser_converged": bool(est.converged_),
        "model_fits": None if gof is None else gof["passed"],
        "warnings": notes,
        "notes": fit_notes(names, th, est.bounds, est.upper_bounds_),
        "iterations": int(est.n_iter_),
        "fixed": fixed,
        "standard_errors": {u: [0.0, 0.0] if u in model.known else [_finite(se[f"{u}_{a}"]), _finite(se[f"{u}_{b}"])]
                            for u, (a, b) in pairs.items()},
        "intervals_95": intervals,
        "goodness_of_fit": gof,
        "starts": [{"estimate": [_finite(x) for x in t], "cost": _finite(c), "converged": ok} for t, c, ok in est.start_results_],
        "message": est.message_,
    }


def write_outputs(out: Path, summary: dict, figure, overwrite: bool = True) -> None:
    """estimate.json and fit.png (drawn by ``figure(path)``) into ``out``, all or nothing."""
    _write_outputs(Path(out), None, None, summary, overwrite, figure)


def _write_outputs(out: Path, stats, moments, summary: dict, overwrite: bool, figure=None) -> None:
    """Create ``out`` (and missing parents) and write fit.png, then estimate.json; on any failure
    or interruption remove what this call created. ``figure(path)`` draws fit.png (default: the
    chaos model's moments against ``stats``)."""
    created = []
    try:
        for folder in [*reversed(out.parents), out]:
            if not folder.exists():
                folder.mkdir()
                created.append(folder)
        with atomic_path(out / "fit.png", overwrite) as tmp:
            (figure or (lambda path: _figure(stats, moments, path)))(tmp)
        created.append(out / "fit.png")
        with atomic_path(out / "estimate.json", overwrite) as tmp:
            tmp.write_text(json.dumps(summary, indent=2, allow_nan=False) + "\n")
    except BaseException:
        for path in reversed(created):
            if path.is_dir():
                try:
                    path.rmdir()
                except OSError:
                    pass  # someone else put files there meanwhile: leave it
            else:
                path.unlink(missing_ok=True)
        raise


def _figure(stats, moments, path, status=None):
    """fit.png of a chaos-model fit: measured statistics (xarray) against the model's moments, the
    fit's ``status`` in the title (saved to ``path``; returned as a Figure when ``path`` is None)."""
    from ..plots.fit import fit_figure  # here: matplotlib is loaded by the commands that draw, not by discover's warnings

    model = None if moments is None else (moments.mean, moments.std)
    return fit_figure(stats["time"].values, stats["mean"].values, stats["std"].values, model, path,
                      channels=[str(c) for c in stats["state"].values], status=status)

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

import copy
import json
import math
import warnings
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from ..io import DataError, atomic_path, check_run_count, check_spread, present_channels, read_ensemble, speed_profile
from ..inference.identify import DistributionEstimator, WeightContext, configured_optimiser, configured_state_scale, state_weights
from ..vehicle.channels import CHANNEL_UNITS, ChannelChaosModel
from ..vehicle.chaos import LSTChaosModel
from ..vehicle.montecarlo import spin_mask
from ..vehicle.statistics import ensemble_statistics, kl_divergence_series, used_samples
from ..vehicle.single_track import STATES

__all__ = ["identify_file", "fit_warnings"]

UNCERTAIN = ("mu", "l_f", "F_w_mean")
#: Below this many runs the sampling error of the runs' own distribution is named in the estimate's notes.
FEW_RUNS = 100


def _model_config(config: Mapping[str, Any], ds, source: str) -> dict:
    """The config with the measured grid and speed (the model runs on the data's time grid)."""
    t = ds["time"].values.astype(float)
    if abs(t[0]) > 1e-9:
        raise DataError(f"{source}: 'time' starts at {t[0]:g} s; the model starts from straight driving at t = 0: "
                        "subtract the start time from the time coordinate")
    cfg = copy.deepcopy(dict(config))
    dt = float(t[1] - t[0])
    cfg["time"] = {"t_end": float(t[-1]), "dt": dt, "step": dt}
    v = float(ds.attrs["v_c"]) if "v" not in ds else float(np.ravel(ds["v"].values)[0])
    cfg["vehicle"] = dict(cfg["vehicle"], speed_kmh=v * 3.6)
    return cfg


def _dst_divergence(cfg, delta):
    """D_KL(NLST || LST) of the synthetic reality under the measured input (DST weights)."""
    from ..vehicle.montecarlo import STEERS, simulate_ensemble
    from ..vehicle.single_track import steering_input

    st = cfg["steering"]
    for steer, sign in STEERS.items():
        if np.allclose(delta, steering_input(np.arange(delta.size) * cfg["time"]["dt"], np.deg2rad(st["delta_max_deg"]), st["period"], sign), atol=1e-6):
            stats = {m: ensemble_statistics(simulate_ensemble(cfg, m, steer), cfg["montecarlo"]["spin_policy"]) for m in ("lst", "nlst")}
            return kl_divergence_series(stats["nlst"], stats["lst"]).values
    raise DataError("the DST cost needs the synthetic reality (LST and NLST) under the same input; "
                    "the measured delta is neither (5.5) nor (5.7) of the config: use --cost std or inp")


def _lost_control(ds, cfg, source: str):
    """Spin flags from the data, the file's own flags (or None) and the dataset carrying the former."""
    threshold = float(cfg["montecarlo"]["spin_threshold"])
    if "beta" not in ds:  # no side slip recorded: lost control cannot be told from the data
        in_file = ds["spun"].values.astype(bool) if "spun" in ds else None
        spun = np.zeros(ds.sizes["sample"], bool) if in_file is None else in_file
        ds = ds.assign(spun=("sample", spun.astype(np.int8), {"units": "1", "long_name": "lost control, from the file's flags"}))
        mask = used_samples(ds, cfg["montecarlo"]["spin_policy"])
        check_spread(ds, source, mask)
        return ds, spun, None
    spun = spin_mask(ds["beta"].values, threshold)
    in_file = ds["spun"].values.astype(bool) if "spun" in ds else None
    ds = ds.assign(spun=("sample", spun.astype(np.int8), {"units": "1", "long_name": f"lost control (|beta| > {threshold} rad), from the data"}))
    mask = used_samples(ds, cfg["montecarlo"]["spin_policy"])
    if mask.sum() < 2:
        raise DataError(f"{source}: only {int(mask.sum())} of {mask.size} realisations kept control (|beta| <= {threshold:g} rad); "
                        "mean and std need at least 2: give more realisations or set montecarlo.spin_policy: keep in the config")
    check_spread(ds, source, mask)
    return ds, spun, in_file


def fit_warnings(theta, theta0, bounds, names, converged: bool, message: str) -> list[str]:
    """Why a fit is not to be trusted: the optimiser's own verdict, an estimate on a bound of the
    box, or the starting point returned unchanged (the cost does not respond to the parameters)."""
    out = [] if converged else [f"the optimiser stopped without converging: {message}"]
    theta, theta0 = np.asarray(theta, float), np.asarray(theta0, float)
    if not np.all(np.isfinite(theta)):
        return out + ["the estimate is not finite"]
    lo, hi = np.array(bounds, float).T
    tol = 1e-6 * (hi - lo)
    for name, value, a, b, eps in zip(names, theta, lo, hi, tol):
        if value <= a + eps or value >= b - eps:
            out.append(f"{name} = {value:.6g} ended at the bound {a if value <= a + eps else b:g} of its search box: the data lie "
                       "outside what the model reaches (check units, v_c and --m-load)")
    if np.all(np.abs(theta - theta0) <= 1e-10 * np.maximum(np.abs(theta0), 1.0)):
        out.append("the fit returned its starting point unchanged: the cost does not respond to the parameters (check the data)")
    return out


def _channel_notes(cfg, ds, channels, speed) -> list[str]:
    """What the recorded channels cannot answer: parameters they cannot separate, lost control
    without beta, unit conversions, runs at different speeds."""
    from ..inference.identifiability import unidentifiable_parameters

    # the four states identify every parameter fitted here (thesis sec. 5.3.1): the test is for subsets
    open_ = {} if channels == STATES else unidentifiable_parameters(cfg, channels, UNCERTAIN)
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
    source = str(measured)
    ds = read_ensemble(measured)
    check_run_count(ds.sizes["sample"], source, "identify")
    channels = present_channels(ds)
    speed = speed_profile(ds)
    if cost == "dst" and (channels != STATES or speed is not None):
        raise DataError(f"{source}: the DST cost compares the LST and NLST states at constant speed; this file has channels "
                        f"{', '.join(channels)}{' and a changing speed' if speed is not None else ''}: use --cost std or inp")
    cfg = _model_config(config, ds, source)
    policy = cfg["montecarlo"]["spin_policy"]
    ds, spun, in_file = _lost_control(ds, cfg, source)
    stats = ensemble_statistics(ds, policy, channels)
    scale = state_scale or configured_state_scale(cfg)
    try:
        state_weights(scale, stats["mean"].values, stats["std"].values)
    except ValueError:
        raise DataError(f"{source}: a state's measured {'mean' if scale == 'rms_mean' else 'std'} is zero throughout, so "
                        f"--state-scale {scale} cannot scale it; use --state-scale none") from None
    delta = ds["delta"].values
    m_load = float(cfg["uncertainty"]["m_load"]["mean"] if m_load is None else m_load)
    model = LSTChaosModel(cfg, uncertain=UNCERTAIN, time_variant_wind=False, order=cfg["identification"]["order"],
                          quadrature_points=cfg["identification"]["quadrature_points"], fixed={"m_load": m_load}, delta=delta)
    if channels != STATES or speed is not None:
        model = ChannelChaosModel(model, channels, speed)
    kl = _dst_divergence(cfg, delta) if cost == "dst" else None
    theta0 = LSTChaosModel.theta_from_config(cfg, UNCERTAIN)
    est = DistributionEstimator(model, cost, starts=starts, rng=np.random.default_rng(cfg["seed"]), max_iter=cfg["identification"]["max_iter"],
                                wheelbase=cfg["vehicle"]["wheelbase"], state_scale=scale,
                                optimiser=configured_optimiser(cfg))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            est.fit(stats["mean"].values, stats["std"].values, theta0, WeightContext(delta, kl))
        except ValueError as exc:  # the model cannot be evaluated at the config's start for these data
            raise DataError(f"{source}: the model cannot follow these data from the config's starting values ({exc}); "
                            "check v_c, the units of the states and the config's uncertainty means") from None
    th, err = est.theta_, est.theta_std_
    notes = fit_warnings(th, theta0, est.bounds, model.theta_names, est.converged_, est.message_)
    converged = bool(est.converged_) and not notes
    notes += [m for m in dict.fromkeys(str(w.message) for w in caught) if not m.startswith("identification did not converge")]
    notes += _channel_notes(cfg, ds, channels, speed)
    n_used = int(stats.attrs["n_used"])
    sampling = _sampling_errors(th, n_used)["mu"]
    info = []  # facts to read the estimate by, not failures (those are the warnings)
    if n_used < FEW_RUNS and sampling[0] is not None and err[0] < sampling[0] / 3:
        info.append(f"with {n_used} runs the runs' own mean of mu is uncertain by about {sampling[0]:.2g} (std / sqrt(n)), "
                     f"more than the fit's standard error {err[0]:.2g}: read mu's mean as +- {sampling[0]:.2g} (sampling_errors)")
    flagged = None if in_file is None else np.flatnonzero(in_file).tolist()
    if flagged is not None and flagged != np.flatnonzero(spun).tolist():
        notes.append(f"the file's 'spun' flags ({len(flagged)}) disagree with the data criterion |beta| > "
                     f"{cfg['montecarlo']['spin_threshold']:g} rad ({int(spun.sum())}); the data criterion was used")
    summary = {
        "mu": [_finite(th[0]), _finite(th[1])],
        "l_f": [_finite(th[2]), _finite(th[3])],
        "F_w_mean": [_finite(th[4]), _finite(th[5])],
        "cost": _finite(est.cost_),
        "converged": converged,
        "warnings": notes,
        "notes": info,
        "iterations": int(est.n_iter_),
        "cost_function": cost,
        "state_scale": scale,
        "m_load": m_load,
        "standard_errors": {k: [_finite(err[2 * i]), _finite(err[2 * i + 1])] for i, k in enumerate(UNCERTAIN)},
        "sampling_errors": _sampling_errors(th, int(stats.attrs["n_used"])),
        "channels": list(channels),
        "speed": "constant" if speed is None else f"profile {float(speed.min()):.4g}-{float(speed.max()):.4g} m/s",
        "samples": int(ds.sizes["sample"]),
        "samples_used": int(stats.attrs["n_used"]),
        "spin_policy": policy,
        "spin_threshold": float(cfg["montecarlo"]["spin_threshold"]),
        "n_spun": int(spun.sum()),
        "spun_indices": np.flatnonzero(spun).tolist(),
        "message": est.message_,
        "measured": source,
    }
    if flagged is not None:
        summary["spun_in_file_indices"] = flagged
    _write_outputs(Path(out), stats, est.moments_, summary, overwrite)
    return summary


def _write_outputs(out: Path, stats, moments, summary: dict, overwrite: bool) -> None:
    """Create ``out`` (and missing parents) and write fit.png, then estimate.json; on any failure
    or interruption remove what this call created."""
    created = []
    try:
        for folder in [*reversed(out.parents), out]:
            if not folder.exists():
                folder.mkdir()
                created.append(folder)
        with atomic_path(out / "fit.png", overwrite) as tmp:
            _figure(stats, moments, tmp)
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


def _figure(stats, moments, path):
    from ..plots.figure import save_figure, state_axes

    channels = [str(c) for c in stats["state"].values]
    fig, axes = state_axes(nrows=(len(channels) + 1) // 2 if len(channels) > 1 else 1, ncols=2 if len(channels) > 1 else 1,
                           title="Identified model (PCE) vs measured ensemble: mean +- 3 std")
    t = stats["time"].values
    for ax in axes[len(channels):]:
        ax.set_visible(False)
    for i, (ax, state) in enumerate(zip(axes, channels)):
        m, s = stats["mean"].values[i], stats["std"].values[i]
        ax.fill_between(t, m - 3 * s, m + 3 * s, color="C0", alpha=0.25, label="measured")
        ax.plot(t, m, color="C0")
        if moments is not None:
            ax.plot(t, moments.mean[i], "C3--", label="identified")
            ax.plot(t, moments.mean[i] + 3 * moments.std[i], "C3:", lw=0.8)
            ax.plot(t, moments.mean[i] - 3 * moments.std[i], "C3:", lw=0.8)
        ax.set_title(state if state in STATES else f"{state} [{CHANNEL_UNITS[state]}]")
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    save_figure(fig, path)

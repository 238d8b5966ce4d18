"""``uqdrive identify``: fit the Table 5.4 model to any ensemble in the uqdrive schema and write
``estimate.json`` and a fitted-vs-measured figure; every input problem is a clear error.
"""

from __future__ import annotations

import copy
import json
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from ..io import DataError, atomic_path, read_ensemble
from ..inference.identify import DistributionEstimator, WeightContext, configured_optimiser, configured_state_scale
from ..vehicle.chaos import LSTChaosModel
from ..vehicle.statistics import ensemble_statistics, kl_divergence_series
from ..vehicle.single_track import STATES

__all__ = ["identify_file"]

UNCERTAIN = ("mu", "l_f", "F_w_mean")


def _model_config(config: Mapping[str, Any], ds) -> dict:
    """The config with the measured grid and speed (the model runs on the data's time grid)."""
    t = ds["time"].values
    if abs(t[0]) > 1e-9:
        raise DataError(f"time must start at 0 s (the model starts at rest); it starts at {t[0]} s")
    cfg = copy.deepcopy(dict(config))
    dt = float(t[1] - t[0])
    cfg["time"] = {"t_end": float(t[-1]), "dt": dt, "step": dt}
    cfg["vehicle"] = dict(cfg["vehicle"], speed_kmh=float(ds.attrs["v_c"]) * 3.6)
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


def identify_file(config: Mapping[str, Any], measured: Path, cost: str, m_load: float | None, starts: int, out: Path,
                  state_scale: str | None = None) -> dict:
    """Identify from the ensemble file ``measured``; write ``out/estimate.json`` and ``out/fit.png``.

    ``state_scale`` (None: the config's ``identification.state_scale``) selects the per-state
    residual scale of (5.25), see :data:`uqdrive.identify.STATE_SCALES`.
    """
    ds = read_ensemble(measured)
    if ds.sizes["sample"] < 2:
        raise DataError(f"{measured}: {ds.sizes['sample']} sample(s); mean and std need at least 2")
    cfg = _model_config(config, ds)
    policy = cfg["montecarlo"]["spin_policy"]
    stats = ensemble_statistics(ds, policy)
    delta = ds["delta"].values
    m_load = float(cfg["uncertainty"]["m_load"]["mean"] if m_load is None else m_load)
    model = LSTChaosModel(cfg, uncertain=UNCERTAIN, time_variant_wind=False, order=cfg["identification"]["order"],
                          quadrature_points=cfg["identification"]["quadrature_points"], fixed={"m_load": m_load}, delta=delta)
    kl = _dst_divergence(cfg, delta) if cost == "dst" else None
    theta0 = LSTChaosModel.theta_from_config(cfg, UNCERTAIN)
    scale = state_scale or configured_state_scale(cfg)
    est = DistributionEstimator(model, cost, starts=starts, rng=np.random.default_rng(cfg["seed"]), max_iter=cfg["identification"]["max_iter"],
                                wheelbase=cfg["vehicle"]["wheelbase"], state_scale=scale,
                                optimiser=configured_optimiser(cfg))
    est.fit(stats["mean"].values, stats["std"].values, theta0, WeightContext(delta, kl))
    th, err = est.theta_, est.theta_std_
    summary = {
        "mu": [float(th[0]), float(th[1])],
        "l_f": [float(th[2]), float(th[3])],
        "F_w_mean": [float(th[4]), float(th[5])],
        "cost": est.cost_,
        "converged": bool(est.converged_),
        "iterations": int(est.n_iter_),
        "cost_function": cost,
        "state_scale": scale,
        "m_load": m_load,
        "standard_errors": {"mu": [float(err[0]), float(err[1])], "l_f": [float(err[2]), float(err[3])], "F_w_mean": [float(err[4]), float(err[5])]},
        "samples_used": int(stats.attrs["n_used"]),
        "spin_policy": policy,
        "message": est.message_,
        "measured": str(measured),
    }
    _figure(stats, est.moments_, out / "fit.png")
    with atomic_path(out / "estimate.json") as tmp:
        tmp.write_text(json.dumps(summary, indent=2) + "\n")
    return summary


def _figure(stats, moments, path):
    from ..plots.figure import save_figure, state_axes

    fig, axes = state_axes(title="Identified model (PCE) vs measured ensemble: mean +- 3 std")
    t = stats["time"].values
    for i, (ax, state) in enumerate(zip(axes, STATES)):
        m, s = stats["mean"].values[i], stats["std"].values[i]
        ax.fill_between(t, m - 3 * s, m + 3 * s, color="C0", alpha=0.25, label="measured")
        ax.plot(t, m, color="C0")
        if moments is not None:
            ax.plot(t, moments.mean[i], "C3--", label="identified")
            ax.plot(t, moments.mean[i] + 3 * moments.std[i], "C3:", lw=0.8)
            ax.plot(t, moments.mean[i] - 3 * moments.std[i], "C3:", lw=0.8)
        ax.set_title(state)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    save_figure(fig, path)

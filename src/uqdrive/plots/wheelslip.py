"""Figures of the GP wheel-slip paper (Figs 4-8), the PID schedule, the slope calibration and the
closed-loop braking study; each made from datasets on disk.
"""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import xarray as xr  # noqa: E402

from ..wheelslip.quarter_car import QuarterCar, closed_loop_poles, friction_curve, pid_gains  # noqa: E402

__all__ = ["friction_curves", "gp_function", "gp_slope", "pole_locations", "pid_schedule_figure", "calibration_figure", "closed_loop_figure"]


def friction_curves(car: QuarterCar, mu_H_values):
    """Paper Fig. 4: the friction curve (27) for several peak frictions mu_H."""
    fig, ax = plt.subplots(figsize=(7, 4), constrained_layout=True)
    slip = np.linspace(0, 1, 501)
    for mu_H in mu_H_values:
        ax.plot(slip, friction_curve(slip, mu_H, car.k), label=f"mu_H = {mu_H:g}")
    ax.set(xlabel="slip lambda [-]", ylabel="friction mu [-]", title="Tyre slip/friction curves (27)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    return fig


def _band(ax, x, mean, std, truth, label):
    ax.plot(x, truth, "k", lw=2, label="true")
    ax.plot(x, mean, "C0", lw=1, label=f"GP mean {label}")
    ax.plot(x, mean + 2 * std, "C0--", lw=0.8, label="+- 2 sigma")
    ax.plot(x, mean - 2 * std, "C0--", lw=0.8)
    ax.grid(alpha=0.3)


def gp_function(ds: xr.Dataset):
    """Paper Fig. 5: GP of the friction coefficient with 2 sigma band, truth and training data."""
    fig, ax = plt.subplots(figsize=(7, 4), constrained_layout=True)
    _band(ax, ds["slip"], ds["mu_mean"], ds["mu_std"], ds["mu_true"], "")
    ax.plot(ds["train_slip"], ds["train_mu"], "o", color="C3", ms=4, label=f"{ds.attrs['n_train']} noisy points + mu(0) = 0")
    ax.set(xlabel="slip lambda [-]", ylabel="mu [-]", ylim=(-0.5, 1.8), title="GP model of the friction coefficient")
    ax.legend(fontsize=8)
    return fig


def gp_slope(ds: xr.Dataset):
    """Paper Fig. 6: GP of the slope d mu / d lambda with 2 sigma band and the true slope."""
    fig, ax = plt.subplots(figsize=(7, 4), constrained_layout=True)
    _band(ax, ds["slip"], ds["slope_mean"], ds["slope_std"], ds["slope_true"], "slope")
    ax.axvline(ds.attrs.get("lambda_star", 0.15), color="grey", ls=":")
    ax.set(xlabel="slip lambda [-]", ylabel="d mu / d lambda [-]", ylim=(-8, 30), title="GP model of the friction slope")
    ax.legend(fontsize=8)
    return fig


def pole_locations(ds: xr.Dataset):
    """Paper Figs 7/8: mean closed-loop poles, the 95 % arc [zeta-, zeta+] and the true poles."""
    fig, ax = plt.subplots(figsize=(3.6, 5.2), constrained_layout=True)  # the equal-aspect axes are tall: no side margins
    w0 = ds.attrs["omega_0"]
    zetas = np.linspace(ds.attrs["zeta_minus"], ds.attrs["zeta_plus"], 100)
    arc = closed_loop_poles(zetas, w0)
    ax.plot(arc[:, 0].real, arc[:, 0].imag, color="0.6", lw=6, label="95 % region")
    ax.plot(arc[:, 1].real, arc[:, 1].imag, color="0.6", lw=6)
    mean = closed_loop_poles(0.5 * (ds.attrs["zeta_minus"] + ds.attrs["zeta_plus"]), w0)
    ax.plot(mean.real, mean.imag, "x", ms=10, mew=2, label="mean")
    true = closed_loop_poles(ds.attrs["zeta_true"], w0)
    ax.plot(true.real, true.imag, "o", mfc="none", ms=10, mew=2, label="true slope")
    phi = np.linspace(np.pi / 2, 3 * np.pi / 2, 200)
    ax.plot(w0 * np.cos(phi), w0 * np.sin(phi), "k:", lw=0.8, label="|s| = omega_0")
    ax.axvline(0, color="k", lw=0.8)
    ax.set(xlabel="Re s [1/s]", ylabel="Im s [1/s]", title=f"Poles at v = {ds.attrs['speed']:g} m/s, {ds.attrs['n_train']} training points", aspect="equal")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="center left")
    return fig


def pid_schedule_figure(car: QuarterCar, mean_slopes: dict, speed_range):
    """K_p(v) and T_i(v) of (28)-(29) for the paper's E(Gamma) and uqdrive's GP estimates."""
    v = np.linspace(*speed_range, 200)
    fig, axes = plt.subplots(1, 2, figsize=(10, 4), constrained_layout=True)
    for label, slope in mean_slopes.items():
        K_p, T_i, _ = pid_gains(slope, v, car)
        axes[0].plot(v, K_p, label=label)
        axes[1].plot(v, T_i, label=label)
    axes[0].set(xlabel="speed v [m/s]", ylabel="K_p", title="K_p(v), eq. (28)")
    axes[1].set(xlabel="speed v [m/s]", ylabel="T_i [s]", title="T_i(v), eq. (29)")
    for ax in axes:
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    return fig


def calibration_figure(cals):
    """Coverage of the true slope by the GP 95 % interval, with Clopper-Pearson intervals."""
    fig, ax = plt.subplots(figsize=(7, 4), constrained_layout=True)
    labels, values, lows, highs = [], [], [], []
    for ds in cals:
        n = ds.attrs["n_train"]
        for key, name in (("ml", "max. likelihood"), ("mcmc", "emcee hyperparameters"), ("prior", "truth from GP prior")):
            sets = ds.attrs[f"{key}_sets"]
            if sets:
                labels.append(f"{n} pts\n{name}")
                values.append(ds.attrs[f"{key}_hits"] / sets)
                lows.append(ds.attrs[f"{key}_ci_low"])
                highs.append(ds.attrs[f"{key}_ci_high"])
    x = np.arange(len(values))
    values, lows, highs = map(np.array, (values, lows, highs))
    ax.errorbar(x, values, yerr=[values - lows, highs - values], fmt="o", capsize=4)
    ax.axhline(0.95, color="k", ls=":", label="nominal 95 %")
    ax.set_xticks(x, labels, fontsize=7)
    ax.set(ylabel="coverage of the true slope", ylim=(min(0.5, lows.min() - 0.05), 1.01), title="Calibration of the GP slope interval at lambda*")
    ax.grid(alpha=0.3)
    ax.legend()
    return fig


def closed_loop_figure(ds: xr.Dataset):
    """Slip under the GP-tuned PID for posterior friction curves and the truth; damping vs band."""
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(11, 4), constrained_layout=True)
    true_i = ds.attrs["true_curve_index"]
    t = ds["time"].values
    ax.plot(t, ds["slip"].values[:, :true_i], color="C0", lw=0.4, alpha=0.4)
    ax.plot(t, ds["slip"].values[:, true_i], "k", lw=2, label="true curve")
    ax.axhline(ds.attrs["lambda_star"], color="C3", ls=":", label="set-point")
    ax.set(xlabel="time [s]", ylabel="slip [-]", ylim=(0, 0.4), title=f"{true_i} GP posterior curves: {100 * ds.attrs['fraction_stable']:.0f} % stable")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    z = ds["zeta"].values
    bx.hist(z[:true_i], bins=30, color="C0", alpha=0.7)
    bx.axvspan(ds.attrs["zeta_minus"], ds.attrs["zeta_plus"], color="0.8", alpha=0.5, label="predicted [zeta-, zeta+]")
    bx.axvline(z[true_i], color="k", lw=2, label="true curve")
    bx.set(xlabel="damping of the linearised loop", ylabel="curves", title=f"{100 * ds.attrs['fraction_in_band']:.0f} % inside the band")
    bx.legend(fontsize=8)
    return fig

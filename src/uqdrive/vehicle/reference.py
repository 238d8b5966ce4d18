"""Per-realisation reference solutions of an ensemble with scipy's solve_ivp: the baseline of the
speed benchmarks and, with tight tolerances, the yardstick of the accuracy tests.
"""

from __future__ import annotations

import numpy as np
import xarray as xr
from scipy.integrate import solve_ivp

from ..settings import Settings
from .montecarlo import STEERS, gust_input_column
from .uncertainty import KarhunenLoeve
from .dynamics.rhs import nlst_rhs
from .single_track import VehicleParameters, lst_matrices, steering_input, wind_yaw_moment

__all__ = ["solve_realisations"]


def solve_realisations(
    settings: Settings,
    ensemble: xr.Dataset,
    kle: KarhunenLoeve,
    samples,
    method: str = "RK45",
    rtol: float = 1e-3,
    atol: float = 1e-6,
) -> np.ndarray:
    """Integrate chosen realisations of an ensemble one by one with ``solve_ivp``.

    Uses the ensemble's own parameter draws and wind germs, the model and steering named in its
    attributes, and evaluates the wind by Nystrom interpolation (5.20) at every requested time.
    The defaults (RK45, rtol 1e-3, atol 1e-6) are MATLAB ode45's method and default tolerances.

    Parameters
    ----------
    settings : Settings
        The settings the ensemble was made with.
    ensemble : xarray.Dataset
        Simulated ensemble (needs ``mu``, ``m_load``, ``l_f``, ``F_w_mean``, ``xi_wind``).
    kle : KarhunenLoeve
        The KLE the ensemble was made with.
    samples : sequence of int
        Indices of the realisations to solve.

    Returns
    -------
    ndarray, shape (len(samples), n_time, 4)
    """
    t = ensemble["time"].values
    st = settings.steering
    delta_max, period, sign = st.delta_max, st.period, STEERS[ensemble.attrs["steer"]]
    coeffs = settings.wind.sigma * ensemble["xi_wind"].values * np.sqrt(kle.eigenvalues)
    linear = ensemble.attrs["model"] == "lst"
    gust_yaw = bool(settings.wind.gust_yaw_moment)
    runs = []
    for j in samples:
        p = VehicleParameters.from_settings(
            settings, mu=float(ensemble.mu[j]), m_load=float(ensemble.m_load[j]), l_f=float(ensemble.l_f[j])
        )
        F_mean, c = float(ensemble.F_w_mean[j]), coeffs[j]
        if linear:
            A, B, W = lst_matrices(p)
            W_gust = gust_input_column(W, gust_yaw)

            def rhs(tt, x):
                gust = c @ kle.eigenfunctions(np.array([tt]))[:, 0]
                return A @ x + B * steering_input(tt, delta_max, period, sign) + W * F_mean + W_gust * gust
        else:

            def rhs(tt, x):
                gust = c @ kle.eigenfunctions(np.array([tt]))[:, 0]
                yaw = wind_yaw_moment(p.M_c, F_mean, gust, gust_yaw)
                return nlst_rhs(x[:, None], steering_input(tt, delta_max, period, sign), F_mean + gust, p, yaw)[:, 0]

        sol = solve_ivp(rhs, (t[0], t[-1]), np.zeros(4), t_eval=t, method=method, rtol=rtol, atol=atol)
        runs.append(sol.y.T)
    return np.stack(runs)

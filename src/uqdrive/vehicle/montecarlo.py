"""Monte Carlo ensembles of the stochastic single-track vehicle (thesis sec. 5.1): the draws, the
data set in the uqdrive schema, spin detection and chunked moments over the ensemble simulators.
"""

from __future__ import annotations

from typing import Any, Mapping

import numpy as np
import xarray as xr

from .._version import __version__
from ..settings import Settings
from .uncertainty import KarhunenLoeve, ParameterDistribution, kle_of_wind
from ..numerics.backend import resolve_device
from ..rng import rng_stream
from .dynamics.engine import EnsembleSimulator
from .dynamics.ensemble import lateral_acceleration, simulate_lst
from .effects import ModelStructure
from .single_track import A_Y_UNIT, STATE_NAMES, STATE_UNITS, STATES, VehicleParameters, gust_input_column, steering_input

__all__ = [
    "MODELS",
    "STEERS",
    "wind_kle",
    "spin_mask",
    "simulate_ensemble",
    "lst_response",
    "monte_carlo_moments",
]

MODELS = ("lst", "nlst")
STEERS = {"normal": 1.0, "inverted": -1.0}
#: The thesis' non-linear single-track model (5.3): the Magic Formula, heading kinematics.
NLST = ModelStructure(tyre="magic_formula")


def wind_kle(settings: Settings) -> KarhunenLoeve:
    """KLE (5.16)-(5.22) of the unit side-wind process over the settings' horizon [0, t_end] (s)
    with their wind's quadrature and truncation."""
    return kle_of_wind(settings.wind, settings.time.t_end)


def _wind_modes(kle: KarhunenLoeve, sigma: float, xi_wind):
    """Coefficients c (n, n_c) with F_w(t) = F_w_mean + c @ f(t), from (5.1) and (5.21)."""
    return sigma * np.asarray(xi_wind) * np.sqrt(kle.eigenvalues)


def spin_mask(beta, threshold: float):
    """Realisations that lose control: |beta| exceeds ``threshold`` (rad) at any time.

    Parameters
    ----------
    beta : ndarray, shape (n, n_time)
        Side-slip angle of each realisation (rad).
    threshold : float
        |beta| (rad) above which a realisation lost control.

    Returns
    -------
    ndarray of bool, shape (n,)
    """
    return np.any(np.abs(beta) > threshold, axis=-1)


def simulate_ensemble(
    settings: Settings,
    model: str,
    steer: str = "normal",
    samples: int | None = None,
    seed: int | None = None,
    kle: KarhunenLoeve | None = None,
    chunk: int | None = None,
    device: str = "cpu",
) -> xr.Dataset:
    """Simulate a Monte Carlo ensemble in the uqdrive data schema (see ``io.validate_ensemble``).

    Parameters
    ----------
    settings : Settings
        The car, its uncertainty, the wind, steering, time grid, speed and spin threshold.
    model : {"lst", "nlst"}
    steer : {"normal", "inverted"}
        Input (5.5) or (5.7).
    samples, seed : int, optional
        Override the settings' sample count and seed.
    kle : KarhunenLoeve, optional
        Precomputed KLE (else computed from the settings).
    chunk : int, optional
        Index of an independent block of a larger ensemble: its draws come from their own
        random streams, so blocks can be simulated one after another in bounded memory.
    device : {"cpu", "gpu", "auto"}
        Where the NLST is integrated: cpu, the NumPy reference (bit for bit the same on every
        machine); gpu, JAX in float64 on a GPU (:mod:`uqdrive.vehicle.accelerated`; the same numbers as
        the NumPy path to 1e-10 relative, refused without JAX or without a GPU it sees); auto, the GPU
        when there is one, else cpu. The LST's exact discretisation always runs on the CPU.

    Returns
    -------
    xarray.Dataset
        dims (sample, time); states, steering, per-sample draws, spin flags, provenance.
    """
    if model not in MODELS:
        raise ValueError(f"unknown model '{model}'; choose one of {', '.join(MODELS)}")
    if steer not in STEERS:
        raise ValueError(f"unknown steering '{steer}'; choose one of {', '.join(STEERS)}")
    backend = resolve_device(device)
    n = int(settings.samples if samples is None else samples)
    seed = int(settings.seed if seed is None else seed)
    grid = settings.time
    kle = wind_kle(settings) if kle is None else kle

    dist = ParameterDistribution.from_settings(settings.uncertainty)
    keys = () if chunk is None else (int(chunk),)
    germs = dist.sample_germs(rng_stream(seed, "parameters", *keys), n)
    xi_wind = rng_stream(seed, "wind", *keys).standard_normal((n, kle.n_modes))
    draws = dist.from_germs(germs)
    p = VehicleParameters.from_settings(settings, mu=draws["mu"], m_load=draws["m_load"], l_f=draws["l_f"])
    wind_settings, st = settings.wind, settings.steering
    coeffs = _wind_modes(kle, wind_settings.sigma, xi_wind)
    delta_max = st.delta_max

    refine = 1 if model == "lst" else 2
    t_fine = grid.fine(refine)
    delta_fine = steering_input(t_fine, delta_max, st.period, STEERS[steer])
    ramp = settings.speed
    on_jax = backend == "jax" and model == "nlst"
    if model == "lst":  # the one ensemble simulator, on the fine grid (along a profile exact per step, as the PCE channel model)
        x = EnsembleSimulator(settings, t_fine, delta_fine, p.v_c, stride=grid.substeps, speed=None if ramp is None else ramp.on(t_fine), kle=kle,
                              linear_profile="exact").realise(p, draws["F_w_mean"], coeffs)
    elif on_jax:
        from .accelerated.nlst import simulate_nlst_jax

        x = simulate_nlst_jax(p, delta_fine, draws["F_w_mean"], coeffs, kle.eigenfunctions(t_fine), grid, wind_settings.gust_yaw_moment,
                              None if ramp is None else ramp.on(t_fine))
    else:  # the one ensemble simulator, driven by the analytic inputs at every RK4 half step
        simulator = EnsembleSimulator.driven(settings, grid, delta_fine, kle.eigenfunctions(t_fine), p.v_c,
                                             None if ramp is None else ramp.on(t_fine), kle)
        x = simulator.realise(p, draws["F_w_mean"], coeffs, NLST)

    t = grid.output
    speed = np.full(t.size, float(p.v_c)) if ramp is None else ramp.on(t)
    wind = draws["F_w_mean"][:, None] + coeffs @ kle.eigenfunctions(t)
    delta_out = steering_input(t, delta_max, st.period, STEERS[steer])
    a_y = lateral_acceleration(model, x, p, delta_out, wind, speed)
    threshold = settings.spin.threshold
    spun = spin_mask(x[2], threshold)
    data_vars = {
        name: (("sample", "time"), x[i], {"units": STATE_UNITS[name], "long_name": STATE_NAMES[name]})
        for i, name in enumerate(STATES)
    }
    data_vars["a_y"] = (("sample", "time"), a_y, {"units": A_Y_UNIT, "long_name": "lateral acceleration at the centre of gravity"})
    data_vars["delta"] = ("time", delta_out, {"units": "rad", "long_name": "front steering angle"})
    if ramp is not None:
        data_vars["v"] = ("time", speed, {"units": "m/s", "long_name": "vehicle speed"})
    units = {"mu": "1", "m_load": "kg", "l_f": "m", "F_w_mean": "N"}
    for name, value in draws.items():
        data_vars[name] = ("sample", value, {"units": units[name], "long_name": f"drawn {name}"})
    data_vars["xi_wind"] = (("sample", "kle_mode"), xi_wind, {"units": "1", "long_name": "standard normal KLE germs of the side wind"})
    data_vars["spun"] = ("sample", spun.astype(np.int8), {"units": "1", "long_name": f"lost control (|beta| > {threshold} rad)"})
    attrs = {
        "title": f"uqdrive Monte Carlo ensemble ({model.upper()}, {steer} steering)",
        "model": model,
        "steer": steer,
        **({"v_c": float(p.v_c)} if ramp is None else {}),
        "noise_A": 0.0,
        "n_spun": int(spun.sum()),
        "spin_threshold": float(threshold),
        "wind_sigma": float(wind_settings.sigma),
        "gust_yaw_moment": int(wind_settings.gust_yaw_moment),
        "integrator": "exact first-order-hold discretisation" if model == "lst" else "classical RK4" + (" (JAX, float64)" if on_jax else ""),
        "integration_step": float(grid.step),
        "seed": seed,
        "config_hash": settings.ensemble_hash(n, seed, chunk),
        "uqdrive_version": __version__,
    }
    coords = {"sample": np.arange(n), "time": ("time", t, {"units": "s", "long_name": "time"}), "kle_mode": np.arange(kle.n_modes)}
    return xr.Dataset(data_vars, coords=coords, attrs=attrs)


def lst_response(settings: Settings, draws: Mapping[str, Any], steer: str = "normal") -> np.ndarray:
    """LST responses for given parameter sets with the time-variant wind switched off.

    For cross-checks of the PCE against non-intrusive methods (chaospy, SALib): any parameter
    of ``mu``, ``m_load``, ``l_f``, ``F_w_mean`` missing from ``draws`` takes its mean (the mean
    wind its interval's midpoint).

    Parameters
    ----------
    settings : Settings
    draws : mapping of str to ndarray, shape (n,)
        Parameter values per realisation: mu (-), m_load (kg), l_f (m), F_w_mean (N).

    Returns
    -------
    ndarray, shape (4, n, n_out + 1)
    """
    n = len(next(iter(draws.values())))
    full = {k: np.broadcast_to(np.asarray(draws.get(k, v), float), (n,)) for k, v in settings.uncertainty.nominal().items()}
    grid = settings.time
    t_fine = grid.fine(1)
    delta = steering_input(t_fine, settings.steering.delta_max, settings.steering.period, STEERS[steer])
    p = VehicleParameters.from_settings(settings, mu=full["mu"], m_load=full["m_load"], l_f=full["l_f"])
    return simulate_lst(p, delta, full["F_w_mean"], np.zeros((n, 0)), np.zeros((0, t_fine.size)), grid)


def monte_carlo_moments(settings: Settings, model: str, samples: int, chunk: int, seed: int | None = None):
    """Mean and std of every state over a large ensemble, simulated in independent chunks.

    Chunk statistics are merged with Chan et al.'s pairwise update of (count, mean, M2), so a
    10^5-run reference needs the memory of one chunk only.

    Returns
    -------
    mean, std : ndarray, shape (4, n_time)
    n : int
        Realisations used (all of them: the spin policy is for the NLST data sets).
    """
    seed = int(settings.seed if seed is None else seed)
    kle = wind_kle(settings)
    count, mean, m2 = 0, 0.0, 0.0
    for c, start in enumerate(range(0, samples, chunk)):
        m = min(chunk, samples - start)
        ds = simulate_ensemble(settings, model, samples=m, seed=seed, kle=kle, chunk=c)
        x = np.stack([ds[s].values for s in STATES])  # (4, m, T)
        mean_c, m2_c = x.mean(axis=1), ((x - x.mean(axis=1, keepdims=True)) ** 2).sum(axis=1)
        delta = mean_c - mean
        total = count + m
        mean = mean + delta * m / total
        m2 = m2 + m2_c + delta**2 * count * m / total
        count = total
    return mean, np.sqrt(m2 / (count - 1)), count

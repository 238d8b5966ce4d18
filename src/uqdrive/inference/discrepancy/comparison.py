"""The measured data as discovery compares them and how fits of them are compared: chi2 on the
linear models' footing, the tie margin and penalty, the null band each fit is judged by.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import Any, NamedTuple

import numpy as np

from ...rng import rng_stream
from ...settings import Spin
from ...vehicle.channels import CHANNELS
from ...vehicle.noise import estimate_noise_variance
from .band import NullBand, Replicates, band_of_replicates, bootstrap_replicates
from .fit import StructureFit

__all__ = ["Measured", "prepare_measured", "speed_profile", "Compared", "NullBands", "ModelComparison", "criterion"]


class Measured(NamedTuple):
    """Measured channels (C, n, K + 1) on the compared grid, compared indices (K,), noise
    variance per channel (C,), spin threshold (rad, or None), channel names, stride, indices of
    the runs that lost control, runs used."""

    x: np.ndarray; index: np.ndarray; noise: np.ndarray; spin: float | None; channels: tuple; stride: int  # noqa: E702
    spun: np.ndarray; samples_used: int  # noqa: E702


def prepare_measured(ds, spin_policy: Spin, max_times: int) -> Measured:
    """The channels of :data:`uqdrive.vehicle.channels.CHANNELS` that ``ds`` carries, every
    ``stride`` samples from t = 0 (at most ``max_times`` compared times, t = 0 left out), each
    channel's noise variance (:func:`uqdrive.vehicle.noise.estimate_noise_variance`), and the
    spin policy ``spin_policy`` (threshold in rad, keep or exclude). Without beta the
    data cannot tell which runs spun: every run is used and no model realisation is left out
    (spin None).
    """
    channels = tuple(c for c in CHANNELS if c in ds)
    x = np.stack([np.asarray(ds[s].values, float) for s in channels])  # (C, n, T)
    thr = float(spin_policy.threshold)
    has_beta = "beta" in channels
    spun = np.any(np.abs(x[channels.index("beta")]) > thr, axis=-1) if has_beta else np.zeros(x.shape[1], bool)
    exclude = has_beta and spin_policy.policy == "exclude"
    used = ~spun if exclude else np.ones_like(spun)
    T = x.shape[-1]
    stride = max(1, int(np.ceil((T - 1) / max_times)))
    K = (T - 1) // stride
    noise = np.array([estimate_noise_variance(x[i, used], order=4) for i in range(len(channels))])
    return Measured(x[:, used][:, :, : K * stride + 1 : stride], np.arange(1, K + 1), noise, thr if exclude else None, channels, stride,
                    np.flatnonzero(spun), int(used.sum()))


def speed_profile(ds):
    """The data's speed over time (m/s) when it changes (the mean over runs of a ``v`` over
    (sample, time)), None for a constant speed (``v_c``, or a ``v`` that never changes)."""
    if "v" not in ds:
        return None
    v = np.asarray(ds["v"].values, float)
    v = v.mean(axis=0) if v.ndim == 2 else v
    return None if np.all(v == v[0]) else v


@dataclass(frozen=True)
class Compared:
    """What every fit of one dataset shares.

    Attributes
    ----------
    sim : AugmentedSimulator
        The linear models' simulator (moment-matched germs).
    raw_germs : Germs
        The germs as drawn, of which a numerically integrated model uses the first
        ``nonlinear_samples``.
    index : ndarray of int, shape (K,)
        Compared time indices.
    noise : ndarray, shape (C,)
        Measurement-noise variance per channel.
    spin : float or None
        Spin threshold on |beta| (rad).
    n : int
        Measured realisations used.
    delta : ndarray, shape (T,)
        Steering command (rad).
    dt : float
        Output step (s).
    measured, scale : ndarray, shape (2, C, K)
        Measured [mean, std] and the linear models' null-band scale.
    model_samples, nonlinear_samples : int
        Realisations of the linear and of the numerically integrated models.
    """

    sim: Any
    raw_germs: Any
    index: np.ndarray
    noise: np.ndarray
    spin: float | None
    n: int
    delta: np.ndarray
    dt: float
    measured: np.ndarray
    scale: np.ndarray
    model_samples: int
    nonlinear_samples: int

    def scale_for(self, nonlinear: bool) -> np.ndarray:
        """The null-band scale of a model, shape (2, C, K): a numerically integrated one runs on
        fewer realisations, sigma sqrt((1 + n / m_nl) / (1 + n / m)) (sampling of data and model)."""
        if not nonlinear:
            return self.scale
        return self.scale * np.sqrt((1 + self.n / self.nonlinear_samples) / (1 + self.n / self.model_samples))

    def sim_for(self, nonlinear: bool):
        """The model's simulator. A model that needs numerical integration runs on the first
        ``nonlinear_samples`` germs as drawn, not moment-matched: the Magic-Formula ensemble's
        statistics are ruled by its few realisations near loss of control, which matching a
        small set does not fix but moves across the spin threshold (seen: a 150-germ matched
        set turned one excluded realisation into a kept one and multiplied beta's std misfit).
        The same object on every call (fits made in worker processes refer to it)."""
        return self._nonlinear_sim if nonlinear else self.sim

    @cached_property
    def _nonlinear_sim(self):
        return self.sim.with_germs(self.raw_germs.head(self.nonlinear_samples))


@dataclass(frozen=True)
class NullBands:
    """Null bands by parametric bootstrap of fitted models on one dataset (:func:`.band.bootstrap_replicates`).

    Attributes
    ----------
    data : Compared
    seed : int
        Root seed of the bootstrap streams.
    bootstrap : int
        Replicates per band.
    level : float
        Family-wise false-alarm rate.
    """

    data: Compared
    seed: int
    bootstrap: int
    level: float
    _held: dict = field(default_factory=dict, init=False, repr=False, compare=False)

    def replicates(self, base, key: int = 0) -> Replicates:
        """Bootstrap replicates of the fitted ``base`` with the data's sample count and noise
        (:func:`.band.bootstrap_replicates`) from the stream of ``key``; the latest model's are
        kept, so that its null band and its non-linear footing's share them."""
        held = self._held.get("replicates")
        if held is not None and held[0] is base and held[1] == key:
            return held[2]
        d = self.data
        rng = rng_stream(self.seed, "discrepancy_bootstrap", *((key,) if key else ()))
        replicates = bootstrap_replicates(d.sim, base, d.n, d.index, d.noise, d.spin, d.n / d.model_samples, rng, self.bootstrap)
        self._held["replicates"] = (base, key, replicates)
        return replicates

    def null(self, base, key: int = 0) -> NullBand:
        """Bootstrap replicates of the fitted ``base`` (the baseline, or a model with named
        effects) with the data's sample count and noise, each refitted to first order
        (:func:`.band.refit_projection`); ``key`` tells the bootstraps' random streams apart."""
        return band_of_replicates(self.replicates(base, key), base, self.level)

    def footing(self, base) -> NullBand:
        """The null band of the non-linear footing: the bootstrap replicates of ``base``'s
        :meth:`null` band (the same draws: common random numbers, so that the two footings'
        levels err together and a comparison across them does not pay for two bootstraps'
        luck), each compared with ``base``'s model on ``nonlinear_samples`` fresh raw germs of
        its own (the linear model's sampling standing in for the non-linear model's), on the
        wide scale. A non-linear model runs on one such set of germs, whose luck a band without
        it counts as misfit (seen: the roll steer at its true size left a rest of 0.58 on
        discover's germs, 0 to 0.67 on three other sets)."""
        d = self.data
        m, n_modes = d.nonlinear_samples, d.sim.germs.kle.shape[1]
        rng = rng_stream(self.seed, "discrepancy_bootstrap", 99)
        sets = _GermSets(d.sim, [type(d.sim.germs).draw(rng, m, n_modes) for _ in range(self.bootstrap)])
        model = np.array([StructureFit(sets.part(i), d.index, d.noise, d.spin).statistics(base.theta_, base.structure_) for i in range(self.bootstrap)])
        unit = (np.asarray(base.scale_, float) / d.scale_for(True)).ravel()
        return band_of_replicates(self.replicates(base), base, self.level, model=model, ratio=d.n / m, jacobian=base.jacobian_ * unit[:, None])


#: Realisations of one simulation of the footing's germ sets (:class:`_GermSets`), as the bootstrap's.
_PASS_REALISATIONS = 4000


class _GermSets:
    """One model on several sets of germs, each set's realisations handed to a
    :class:`.fit.StructureFit` of its own as its simulator's (:meth:`part`).

    Where the model is integrated by RK4 (along a speed profile, or a non-linear tyre) the sets
    are simulated side by side, as many as fill :data:`_PASS_REALISATIONS`: a realisation's
    arithmetic is its own there, so each set gets the numbers of a simulation of its own, at a
    fraction of the cost (at 300 realisations a step's NumPy calls cost more than their
    arithmetic). The pass's gust forces are one BLAS product, whose rows equal those of each
    set's own product where the kernel does not round a row by its place in the product (on
    OpenBLAS' Haswell kernel an odd set size with eight or more wind modes did; 300 realisations
    with the configured wind's modes did not). Elsewhere each set is a simulation of its own: the exact discretisation
    scales by the largest norm of its batch, the chassis terms pick their sine by the largest angle.
    """

    def __init__(self, sim, germs):
        self.sim, self.germs = sim, list(germs)
        self.per_pass = max(1, _PASS_REALISATIONS // max(g.n for g in self.germs))
        self._pass = (None, [])  # (the pass's key, its sets' realisations): the latest pass only

    def side_by_side(self, structure) -> bool:
        """Whether sets of ``structure``'s model share a simulation (RK4 without the chassis terms)."""
        return (self.sim.speed is not None or structure.nonlinear) and not structure.uses_chassis

    def realisations(self, i: int, theta, structure) -> np.ndarray:
        """Set ``i``'s realisations (C, m, K + 1) of the model (``theta``, ``structure``), from the
        simulation of its pass (simulated at the first set asked for)."""
        per = self.per_pass if self.side_by_side(structure) else 1
        first = i - i % per
        key = (first, np.asarray(theta, float).tobytes(), structure)
        if self._pass[0] != key:
            group = self.germs[first:first + per]
            germs = group[0] if len(group) == 1 else type(group[0])(
                *(np.concatenate([getattr(g, f) for g in group]) for f in ("mu", "l_f", "m_load", "wind", "kle")))
            x = self.sim.with_germs(germs).simulate(theta, structure)
            ends = np.cumsum([0] + [g.n for g in group])
            self._pass = (key, [x[:, a:b] for a, b in zip(ends[:-1], ends[1:])])
        return self._pass[1][i - first]

    def part(self, i: int) -> "_GermSet":
        """Set ``i`` as the simulator of a :class:`.fit.StructureFit`."""
        return _GermSet(self, i)


class _GermSet:
    """One set of :class:`_GermSets` with the part of a simulator's interface a
    :class:`.fit.StructureFit` uses for its statistics: channels, spin row, simulations."""

    def __init__(self, sets: _GermSets, i: int):
        self.sets, self.i = sets, i
        self.channels, self.spin_row = sets.sim.channels, sets.sim.spin_row

    def simulate_many(self, thetas, structures, groups=None) -> list:
        """The set's realisations of each (theta, structure) pair."""
        return [self.sets.realisations(self.i, th, s) for th, s in zip(thetas, structures)]


def criterion(band) -> tuple[float, float]:
    """Null-calibrated tie margin (2 null sd of chi2) and penalty per parameter (2 x inflation) of ``band``."""
    return 2.0 * band.chi2_null_sd, 2.0 * band.inflation


class ModelComparison:
    """Fits of one dataset judged on one footing.

    Parameters
    ----------
    band : NullBand
        The baseline's null band (the linear models' footing).
    scale : ndarray, shape (2, C, K)
        The linear models' null-band scale.
    footing_band : NullBand, optional
        The non-linear footing's band (:meth:`NullBands.footing`); None: no numerically
        integrated model is compared.
    bands : NullBands, optional
        Where a named model's own band is bootstrapped (:meth:`own_band`).
    """

    def __init__(self, band, scale, footing_band=None, bands: NullBands | None = None):
        self.band = band
        self.scale = scale
        self.footing_band = footing_band
        self.bands = bands

    criterion = staticmethod(criterion)

    def footing(self, fit) -> float:
        """Mean squared ratio of the scale ``fit`` was judged with to the linear models' (1: a linear model's footing)."""
        return float(np.mean((np.asarray(fit.scale_, float) / self.scale) ** 2))

    def band_of(self, fit):
        """The null band a fit's z are judged by: the baseline's, or the non-linear footing's."""
        return self.band if self.footing(fit) == 1.0 else (self.footing_band or self.band)

    def chi2(self, fit) -> float:
        """chi2 of a fit on the common footing of the linear models' scale.

        A numerically integrated model runs on fewer realisations, so its z are divided by a
        wider scale (:meth:`Compared.scale_for`): its chi2 then shrinks the systematic misfit by
        that factor squared and would favour it against every linear model. Its excess over the
        null level is converted back: null level + excess x (scale ratio)^2. A chi2 below the
        null level has no systematic part to convert: it stays as it is (scaled, the sampling
        luck of the few realisations would count ratio^2 times and favour every non-linear
        candidate where the gap is small; seen: chassis candidates of zero size 40 below the
        linear model on the same physics).

        The ratio is that of the scale the fit was judged with (``fit.scale_``), not of its final
        structure: a non-linear candidate fitted to zero size has a linear structure but its z
        on the wide scale (seen: a load transfer at h = 0 scored 2100 below the linear baseline
        it equals and won a forward step). Its null level is the non-linear footing's
        (:meth:`NullBands.footing`: the few raw realisations' own sampling included)."""
        ratio2 = self.footing(fit)
        level = self.band.mean_square_null * fit.z_.size
        if ratio2 == 1.0:
            return fit.chi2_
        own = self.band_of(fit).mean_square_null * fit.z_.size
        return level + (fit.chi2_ - own) * (ratio2 if fit.chi2_ > own else 1.0)

    def chi2_bar(self, bar: float, wide: bool) -> float:
        """The chi2 of a fit on its own scale above which its :meth:`chi2` is above ``bar``: the
        inverse of that conversion for a fit judged on the wide scale (``wide``: a numerically
        integrated model's, :meth:`Compared.scale_for`) or on the linear models' (``bar`` itself)."""
        ratio2 = float(np.mean((self.bands.data.scale_for(True) / self.scale) ** 2)) if wide else 1.0
        if ratio2 == 1.0:
            return float(bar)
        level = self.band.mean_square_null * self.scale.size
        own = (self.footing_band or self.band).mean_square_null * self.scale.size
        return own + (bar - level) / (ratio2 if bar > level else 1.0)

    def margin(self, margin: float, *fits) -> float:
        """The tie margin of a comparison of ``fits`` in chi2 on the linear footing: a fit on the
        non-linear footing brings that footing's chi2 spread, converted by its squared scale
        ratio (its few raw realisations' luck, which moment-matched germs do not share)."""
        wide = [f for f in fits if self.footing(f) > 1.0]
        return max([margin] + [2.0 * self.footing(f) * self.band_of(f).chi2_null_sd for f in wide])

    def own_band(self, fit, key: int = 1):
        """The null band of a model with named effects and its kind: its own bootstrap (a
        stronger gust or a sensor gain changes the spread the band normalises by), ``"own"``; a
        non-linear model takes the non-linear footing's (its own bootstrap, B x n realisations
        by RK4, would cost minutes), ``"nonlinear_footing"``."""
        if self.footing(fit) > 1:
            return self.band_of(fit), "nonlinear_footing"
        return self.bands.null(fit, key=key), "own"

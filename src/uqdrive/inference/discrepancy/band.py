"""The null band: how far the measured mean and std trajectories may stray from a model that
misses nothing, and a scan statistic over signal x statistic x time window whose family-wise
false-alarm rate is calibrated by a parametric bootstrap (the maximum over all cells).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...vehicle.dynamics.jit import compiled

__all__ = ["STATISTICS", "moment_statistics", "mean_std", "compared_times", "statistic_scale", "replicate_statistics", "standardised_gap", "refit_projection", "scan_windows", "scan", "NullBand", "excess_rms", "Replicates", "bootstrap_replicates", "band_of_replicates"]

#: The statistics compared, in the order of axis 0 of every statistic array.
STATISTICS = ("mean", "std")


def moment_statistics(x, index):
    """Mean and standard deviation (ddof 1) over realisations at the selected times.

    Parameters
    ----------
    x : ndarray, shape (C, n, T)
        Realisations of the four states.
    index : ndarray of int, shape (K,)
        Selected time indices.

    Returns
    -------
    ndarray, shape (2, C, K)
        [mean, std] per state and time.
    """
    return mean_std(compared_times(x, index))


def compared_times(x, index):
    """x[:, :, index] for x (C, n, T): a view when ``index`` is a run of consecutive times (the
    evenly spaced comparison times at stride 1), else NumPy's copy."""
    if np.all(np.diff(index) == 1):
        return x[:, :, index[0]:index[-1] + 1]
    return x[:, :, index]


@compiled
def _moments(xs):
    C, n, K = xs.shape
    out = np.empty((2, C, K))
    acc = np.empty(K)
    for c in range(C):
        acc[:] = 0.0
        for i in range(n):
            for k in range(K):
                acc[k] += xs[c, i, k]
        for k in range(K):
            out[0, c, k] = acc[k] / n
        acc[:] = 0.0
        for i in range(n):
            for k in range(K):
                d = xs[c, i, k] - out[0, c, k]
                acc[k] += d * d
        for k in range(K):
            out[1, c, k] = np.sqrt(acc[k] / (n - 1))
    return out


def mean_std(xs):
    """[mean, std (ddof 1)] over axis 1 of xs (C, n, K), shape (2, C, K).

    NumPy's mean and std given the mean, bit for bit as they come on a C-contiguous xs of two or
    more times (the sums over the realisations one after the other, the order
    :meth:`.fit.StructureFit.statistics` has always had; the std's sum of squared deviations from
    that mean over n - 1; at K = 1 NumPy sums pairwise, a last bit apart), in one compiled
    loop that reads xs where it lies: a view of the compared times is not copied first (a
    four-wheel discover's 4800 statistics: 3 s by NumPy on its copies).
    """
    return _moments(np.asarray(xs, dtype=float))


def statistic_scale(x, index, model_ratio: float = 0.0, floor: float = 1e-3):
    """Sampling standard deviation of :func:`moment_statistics`, from the data themselves.

    The mean's is s / sqrt(n); the std's follows from the delta method with the fourth central
    moment m4, Var(s) ~ (m4 - s^4) / (4 s^2 n), which holds for non-Gaussian states (s^2 / (2n)
    for Gaussian ones). A model whose moments are themselves estimated from M realisations adds
    its own error: both variances are multiplied by (1 + model_ratio), model_ratio = n / M.

    Parameters
    ----------
    x : ndarray, shape (C, n, T)
    index : ndarray of int, shape (K,)
    model_ratio : float
    floor : float
        Relative floor per statistic and state (fraction of its largest scale), so that times
        where nothing varies yet (t = 0 of noise-free data) do not divide by zero.

    Returns
    -------
    ndarray, shape (2, C, K)
    """
    xs = x[:, :, index]
    n = xs.shape[1]
    s = xs.std(axis=1, ddof=1)
    c = xs - xs.mean(axis=1, keepdims=True)
    m4 = np.mean(c**4, axis=1)
    return _scale_of_moments(s, m4, n, model_ratio, floor)


def _scale_of_moments(s, m4, n: int, model_ratio: float, floor: float):
    """[s / sqrt(n), sqrt(Var s)] * sqrt(1 + model_ratio), floored: the formula of
    :func:`statistic_scale` from the std s and fourth central moment m4 (any shape, time last)."""
    # where nothing varies (s = 0) the std's own spread is 0 and the floor below decides; a
    # 1e-300 guard would square to 0 and give 0 / 0 = NaN there
    var_s = np.divide(np.maximum(m4 - s**4, 0.0), 4.0 * s**2 * n, out=np.zeros_like(s), where=s > 0)
    scale = np.stack([s / np.sqrt(n), np.sqrt(var_s)]) * np.sqrt(1.0 + model_ratio)
    top = scale.max(axis=-1, keepdims=True)
    return np.maximum(scale, floor * np.where(top > 0, top, 1.0))


def replicate_statistics(x, model_ratio: float = 0.0, floor: float = 1e-3):
    """:func:`moment_statistics` and :func:`statistic_scale` of many replicates in one pass.

    The bootstrap of the null band needs both for hundreds of replicates; computing the
    centred values once (mean, then sum c^2 and sum c^4) instead of five reductions per
    statistic halves its cost.

    Parameters
    ----------
    x : ndarray, shape (C, R, n, K)
        R replicates of n realisations of the four states at K times.
    model_ratio, floor : float
        As in :func:`statistic_scale`.

    Returns
    -------
    statistics, scale : ndarray, shape (R, 2, C, K)
        Equal to ``moment_statistics(x[:, r], all)`` and ``statistic_scale(x[:, r], all, ...)``
        for each replicate r (to rounding).
    """
    n = x.shape[2]
    m = x.mean(axis=2)
    c2 = x - m[:, :, None, :]
    np.square(c2, out=c2)
    s = np.sqrt(c2.sum(axis=2) / (n - 1))
    m4 = np.einsum("rsnk,rsnk->rsk", c2, c2) / n
    scale = _scale_of_moments(s, m4, n, model_ratio, floor)
    return np.stack([m, s]).transpose(2, 0, 1, 3), scale.transpose(2, 0, 1, 3)


def standardised_gap(measured, model, scale):
    """z = (measured - model) / scale, all of shape (2, C, K): the gap in units of the null band."""
    return (np.asarray(measured) - np.asarray(model)) / np.asarray(scale)


def refit_projection(z, jacobian):
    """z after a linearised refit: its component in the span of the fit's Jacobian removed.

    A fitted model absorbs the part of the sampling error that its parameters can mimic (the
    sample means of the draws move the mean trajectories like the distribution parameters do),
    so residuals of a fit are smaller than those of the true model. One Gauss-Newton step of a
    refit of a replicate is z - J (J'J)^+ J' z; applying it to every bootstrap replicate
    calibrates the band for fitted residuals.

    Parameters
    ----------
    z : ndarray, shape (B, 2, C, K)
    jacobian : ndarray, shape (2 * 4 * K, p)

    Returns
    -------
    ndarray, shape (B, 2, C, K)
    """
    z = np.asarray(z, float)
    flat = z.reshape(z.shape[0], -1)
    J = np.asarray(jacobian, float)
    if J.size == 0:
        return z
    Q, _ = np.linalg.qr(J)
    return (flat - (flat @ Q) @ Q.T).reshape(z.shape)


def scan_windows(K: int, lengths=(1, 4, 16, 64)):
    """Windows (start, stop) over K time points: each length (capped at K) with half-overlap,
    plus the whole horizon. Returns an int array of shape (n_windows, 2)."""
    out = []
    for L in sorted({min(int(L), K) for L in lengths} | {K}):
        step = max(1, L // 2)
        starts = list(range(0, K - L + 1, step))
        if starts[-1] != K - L:
            starts.append(K - L)
        out += [(s, s + L) for s in starts]
    return np.array(sorted(set(out)), int)


def scan(z, windows):
    """Window sums of z over time divided by sqrt(length), for every statistic and state.

    Parameters
    ----------
    z : ndarray, shape (..., 2, C, K)
    windows : ndarray of int, shape (n_w, 2)

    Returns
    -------
    ndarray, shape (..., 2, C, n_w)
    """
    c = np.concatenate([np.zeros(z.shape[:-1] + (1,)), np.cumsum(z, axis=-1)], axis=-1)
    lengths = windows[:, 1] - windows[:, 0]
    return (c[..., windows[:, 1]] - c[..., windows[:, 0]]) / np.sqrt(lengths)


@dataclass(frozen=True)
class NullBand:
    """Calibration of the scan statistic from bootstrap replicates of a model missing nothing.

    Attributes
    ----------
    windows : ndarray, shape (n_w, 2)
    cell_scale : ndarray, shape (2, C, n_w)
        Bootstrap standard deviation of each scan cell (the cells are divided by it).
    max_null : ndarray, shape (B,)
        The maximum |standardised cell| of every replicate.
    mean_square_null : float
        Mean over replicates of mean(z^2): the misfit level of a model that misses nothing.
    chi2_null_sd : float
        Standard deviation over replicates of sum(z^2).
    inflation : float
        Var(sum z) / sum Var(z) over the replicates, averaged over statistics and states: how
        much correlation in time inflates the error of fitted parameters (1 for independent z).
    level : float
        Family-wise false-alarm rate of :attr:`threshold`.
    chi2_null : ndarray, shape (B,)
        sum(z^2) of every replicate.
    """

    windows: np.ndarray
    cell_scale: np.ndarray
    max_null: np.ndarray
    mean_square_null: float
    chi2_null_sd: float
    inflation: float
    level: float = 0.05
    chi2_null: np.ndarray | None = None

    @classmethod
    def from_replicates(cls, z_null, windows, level: float = 0.05) -> "NullBand":
        """Calibrate from z of B replicates, shape (B, 2, C, K)."""
        cells = scan(z_null, windows)
        scale = cells.std(axis=0, ddof=1)
        scale = np.where(scale > 0, scale, 1.0)
        maxima = np.abs(cells / scale).reshape(cells.shape[0], -1).max(axis=1)
        chi2 = np.sum(z_null**2, axis=(1, 2, 3))
        var_sum = np.var(z_null.sum(axis=-1), axis=0, ddof=1)
        sum_var = np.var(z_null, axis=0, ddof=1).sum(axis=-1)
        inflation = float(np.mean(var_sum / np.maximum(sum_var, 1e-300)))
        return cls(np.asarray(windows), scale, maxima, float(np.mean(z_null**2)), float(np.std(chi2, ddof=1)), max(inflation, 1.0), level, chi2)

    @property
    def _gumbel(self):
        """Location and scale of a Gumbel law fitted to the maxima by moments: the maximum of
        many (correlated) Gaussian cells is Gumbel-like, so a high quantile comes from the whole
        sample of replicates, not from its two or three largest members."""
        scale = float(np.std(self.max_null, ddof=1)) * np.sqrt(6.0) / np.pi
        return float(np.mean(self.max_null)) - 0.5772156649015329 * scale, max(scale, 1e-12)

    @property
    def threshold(self) -> float:
        """(1 - level) quantile of the replicates' maxima (Gumbel fit, see ``_gumbel``)."""
        loc, scale = self._gumbel
        return float(loc - scale * np.log(-np.log(1.0 - self.level)))

    def excess_chi2(self, z) -> float:
        """sum(z^2) beyond the null's mean, in chi2 units (0 on average for a model missing nothing)."""
        z = np.asarray(z, float)
        return float(np.sum(z**2) - self.mean_square_null * z.size)

    def gate(self, z) -> bool:
        """Whether z leaves the null: its scan maximum beyond :attr:`threshold` and its total
        misfit beyond the null mean by more than two null standard deviations of chi2 (a
        crossing of the scan alone, with no excess misfit, is the scan's own false alarm)."""
        return self.max_statistic(z) > self.threshold and self.excess_chi2(z) > 2.0 * self.chi2_null_sd

    def false_alarm_rate(self) -> float:
        """Fraction of the null replicates that pass :meth:`gate`: the calibrated false-alarm
        rate of a verdict other than ``none`` (NaN without the replicates' chi2)."""
        if self.chi2_null is None:
            return float("nan")
        excess = self.chi2_null - np.mean(self.chi2_null)
        return float(np.mean((self.max_null > self.threshold) & (excess > 2.0 * self.chi2_null_sd)))

    def cells(self, z):
        """Standardised scan cells of z (2, C, K): shape (2, C, n_w)."""
        return scan(z, self.windows) / self.cell_scale

    def max_statistic(self, z) -> float:
        """Largest absolute scan cell of the standardised gap ``z`` (shape (2, C, K)), compared with the
        threshold."""
        return float(np.abs(self.cells(z)).max())

    def p_value(self, z) -> float:
        """Probability under the null that the maximum reaches that of z (Gumbel fit)."""
        loc, scale = self._gumbel
        return float(-np.expm1(-np.exp(-(self.max_statistic(z) - loc) / scale)))


def excess_rms(z, band: NullBand) -> float:
    """Gap metric: sqrt(max(mean(z^2) - null level, 0)), the misfit beyond what sampling alone
    gives, in units of the null band (0 for a model that misses nothing)."""
    return float(np.sqrt(max(float(np.mean(np.asarray(z) ** 2)) - band.mean_square_null, 0.0)))


@dataclass(frozen=True)
class Replicates:
    """Bootstrap replicates of one fitted model with the data's sample count and noise.

    Attributes
    ----------
    statistics : ndarray, shape (B, 2, C, K)
        [mean, std] of every replicate (:func:`replicate_statistics`).
    scale : ndarray, shape (B, 2, C, K)
        Their own null-band scale at the model error ratio ``ratio``.
    ratio : float
        The model error ratio n / m of ``scale``.
    """

    statistics: np.ndarray
    scale: np.ndarray
    ratio: float

    def scale_at(self, ratio: float) -> np.ndarray:
        """The replicates' scale at another model error ratio: :func:`statistic_scale` scales by
        sqrt(1 + ratio), its floor included (the same array where ``ratio`` is the replicates')."""
        if ratio == self.ratio:
            return self.scale
        return self.scale * np.sqrt((1.0 + ratio) / (1.0 + self.ratio))


def bootstrap_replicates(sim, base, n: int, index, noise, spin, ratio: float, rng, bootstrap: int) -> Replicates:
    """``bootstrap`` replicates of n realisations of base's model (a :class:`.fit.StructureFit`;
    fresh germs from ``rng``) with the measurement noise (variance ``noise`` (C,), one per measured
    channel of ``sim``) added, their statistics and their own scale (model error ratio ``ratio``),
    realisations beyond ``spin`` (|beta|, rad; None where beta is not measured) left out as in
    the data."""
    per_call = max(1, 4000 // max(n, 1))
    statistics, scales = [], []
    noise_buffer = None  # the draws of every call land in one array: fresh pages cost a third of the draws
    for start in range(0, bootstrap, per_call):
        reps = min(per_call, bootstrap - start)
        germs = type(sim.germs).draw(rng, reps * n, sim.germs.kle.shape[1])
        x = sim.simulate(base.theta_, base.structure_, germs=germs)
        # x[:, :, index] + noise, computed in the noise's array (no copies of x; the same sums)
        shape = (x.shape[0], x.shape[1], index.size)
        size = x.shape[0] * x.shape[1] * index.size
        if noise_buffer is None or noise_buffer.size < size:
            noise_buffer = np.empty(size)
        xb = rng.standard_normal(out=noise_buffer[:size].reshape(shape))
        xb *= np.sqrt(noise)[:, None, None]
        xb += compared_times(x, index)
        xb = xb.reshape(x.shape[0], reps, n, -1)
        keep = np.ones((reps, n), bool) if spin is None else ~np.any(np.abs(xb[sim.spin_row]) > spin, axis=-1)
        whole = keep.all(axis=1) | (keep.sum(axis=1) < 2)  # replicates used with all realisations
        stats, scale = np.empty((reps, 2, x.shape[0], xb.shape[-1])), np.empty((reps, 2, x.shape[0], xb.shape[-1]))
        if whole.any():  # xb itself where every replicate is whole: xb[:, whole] would be a copy of the same numbers
            stats[whole], scale[whole] = replicate_statistics(xb if whole.all() else xb[:, whole], model_ratio=ratio)
        for r in np.flatnonzero(~whole):  # spun realisations left out of their replicate
            stats[r], scale[r] = (a[0] for a in replicate_statistics(xb[:, r, keep[r]][:, None], model_ratio=ratio))
        statistics.append(stats)
        scales.append(scale)
    return Replicates(np.concatenate(statistics), np.concatenate(scales), ratio)


def band_of_replicates(replicates: Replicates, base, level: float, model=None, ratio: float | None = None, jacobian=None) -> NullBand:
    """The null band of ``base`` from its bootstrap ``replicates``: z = (statistics - model) /
    scale of every replicate, refitted to first order (:func:`refit_projection`).

    ``model``: None compares every replicate with ``base.statistics_``; an array (B, 2, C, K)
    gives each replicate's own model statistics (a model evaluated on fresh germs). ``ratio``:
    the model error ratio of the comparison's scale (default the replicates'). ``jacobian``
    (default ``base.jacobian_``): d z / d parameters on that scale.
    """
    scale = replicates.scale if ratio is None else replicates.scale_at(ratio)
    z = (replicates.statistics - (base.statistics_ if model is None else model)) / scale
    z = refit_projection(z, base.jacobian_ if jacobian is None else jacobian)
    return NullBand.from_replicates(z, scan_windows(z.shape[-1]), level)


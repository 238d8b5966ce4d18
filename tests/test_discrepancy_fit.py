"""StructureFit's simulations: a numerically integrated model's difference neighbours simulated in
the pass of their centre, and the statistics taken from the simulators' time-major output, give
the fit the numbers of one simulation per call and of the earlier copies, to the last bit."""

import numpy as np
import pytest

from uqdrive.inference.discrepancy.band import statistic_scale
from uqdrive.inference.discrepancy.fit import StructureFit
from uqdrive.vehicle.augmented import AugmentedSimulator
from uqdrive.vehicle.effects import EFFECTS, ModelStructure

THETA = np.array([1.0, 0.2, 1.55, 0.2, -400.0, 400.0])


@pytest.fixture(scope="module")
def sim(config):
    t = np.arange(301) * 0.01
    delta = np.deg2rad(5.0) * np.sin(2 * np.pi * t / 2.0)
    return AugmentedSimulator.drawn(config, t, delta, 25.0, 24, np.random.default_rng(11), stride=4)


class _OnePassPerCall(StructureFit):
    """The fit without simulating ahead (each call simulates what it asks for)."""

    def _simulate(self, pairs, then=()):
        return super()._simulate(pairs)


class _Counting:
    """The simulator, counting RK4 passes (calls of simulate_many) and simulated pairs."""

    def __init__(self, sim):
        self.sim, self.passes, self.pairs = sim, 0, 0

    def __getattr__(self, name):
        return getattr(self.sim, name)

    def simulate_many(self, thetas, structures, groups=None):
        self.passes += 1
        self.pairs += len(thetas)
        return self.sim.simulate_many(thetas, structures, groups)


@pytest.mark.parametrize("fit_theta", [True, False])
def test_neighbours_simulated_ahead_change_no_number_and_halve_the_passes(sim, fit_theta):
    """A Magic-Formula fit (joint, or the effect alone as in screening) to the statistics of the
    model at E = 0.6: every attribute equal to the one-pass-per-call fit's bit for bit, with
    about half its RK4 passes and no more simulated pairs than the Jacobians need plus the
    neighbours of at most one rejected step per evaluation."""
    index = np.arange(1, sim.output_time.size)
    effect = EFFECTS["tyre_saturation"]
    x = sim.simulate(THETA * [1.05, 1, 1, 1, 1, 1], effect.augment(ModelStructure(), [0.6]))
    noise = np.full(4, 1e-8)
    measured = StructureFit(sim, index, noise, 0.2).statistics(THETA, effect.augment(ModelStructure(), [0.6]))
    scale = statistic_scale(x, index) + 1e-6
    fits = {}
    for cls in (StructureFit, _OnePassPerCall):
        counted = _Counting(sim)
        f = cls(counted, index, noise, 0.2, effect=effect, fit_theta=fit_theta, max_nfev=5)
        fits[cls] = (f.fit(measured, scale, THETA, effect_start=[0.97]), counted)
    (ahead, c_ahead), (plain, c_plain) = fits[StructureFit], fits[_OnePassPerCall]
    for attr in ("theta_", "effect_values_", "statistics_", "z_", "jacobian_", "parameter_cov_"):
        assert np.array_equal(getattr(ahead, attr), getattr(plain, attr)), attr
    assert ahead.chi2_ == plain.chi2_ and ahead.nfev_ == plain.nfev_
    assert c_plain.passes >= 2 * ahead.nfev_ - 1 and c_ahead.passes <= ahead.nfev_ + 1
    p = ahead.jacobian_.shape[1]
    assert c_ahead.pairs <= c_plain.pairs + p * ahead.nfev_


@pytest.mark.parametrize("layout", ["time-major", "C"])
@pytest.mark.parametrize("spun", [0, 3])
def test_statistics_of_any_layout_equal_the_earlier_copies(sim, layout, spun):
    """[mean, std] with the output map and the noise, against the formula of the earlier code
    (x[:, keep][:, :, index], whose sums ran realisation by realisation), bit for bit."""
    rng = np.random.default_rng(4)
    K1, n = 40, 50
    x = (rng.standard_normal((K1, 4, n)) * [[1.0], [2.0], [0.02], [30.0]] + [[0.3], [0.3], [0.0], [0.3]]).transpose(1, 2, 0)
    x = x if layout == "time-major" else np.ascontiguousarray(x)
    x[2, :spun, 7] = 0.5  # beyond the spin threshold: left out
    s = ModelStructure(output_gain=(1.0, 1.1, 1.0, 1.0), output_offset=(0.0, 0.0, 0.01, 0.0))
    noise = np.array([1e-6, 2e-6, 1e-8, 1e-4])
    index = np.arange(1, K1)
    got = StructureFit(sim, index, noise, 0.2)._measured_statistics(x, s)
    keep = ~np.any(np.abs(x[2]) > 0.2, axis=-1)
    xs = x[:, keep][:, :, index]
    gain = np.asarray(s.output_gain)[:, None]
    mean = xs.mean(axis=1) * gain + np.asarray(s.output_offset)[:, None]
    std = np.sqrt((xs.std(axis=1, ddof=1) * gain) ** 2 + noise[:, None])
    assert keep.sum() == n - spun and np.array_equal(got, np.stack([mean, std]))

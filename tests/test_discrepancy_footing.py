"""The non-linear footing's null band: its model's fresh germ sets simulated side by side give every
bootstrap replicate the statistics of a simulation of its own, bit for bit; its data replicates
are the null band's."""

from types import SimpleNamespace

import numpy as np
import pytest

from uqdrive.inference.discrepancy import comparison
from uqdrive.inference.discrepancy.band import band_of_replicates, bootstrap_replicates
from uqdrive.inference.discrepancy.comparison import Compared, NullBands
from uqdrive.inference.discrepancy.fit import StructureFit
from uqdrive.rng import rng_stream
from uqdrive.settings import Settings
from uqdrive.vehicle.augmented import AugmentedSimulator
from uqdrive.vehicle.effects import EFFECTS, ModelStructure
from uqdrive.vehicle.single_track import STATES

THETA = np.array([1.0, 0.1, 1.4, 0.1, -300.0, 300.0])
N, M, B = 200, 40, 30  # data runs, the model's raw realisations, replicates


def _replicate_by_replicate(bands: NullBands, base):
    """The footing's band with one simulation of ``base``'s model per replicate on its fresh germs
    (a StructureFit on a simulator of those germs alone) from the footing's random stream, the
    data's replicates from the null band's stream at the null band's model ratio."""
    d = bands.data
    rng = rng_stream(bands.seed, "discrepancy_bootstrap", 99)
    model = np.array([StructureFit(d.sim.with_germs(type(d.sim.germs).draw(rng, M, d.sim.germs.kle.shape[1])), d.index, d.noise,
                                   d.spin).statistics(base.theta_, base.structure_) for _ in range(bands.bootstrap)])
    replicates = bootstrap_replicates(d.sim, base, d.n, d.index, d.noise, d.spin, d.n / d.model_samples, rng_stream(bands.seed, "discrepancy_bootstrap"),
                                      bands.bootstrap)
    unit = (np.asarray(base.scale_, float) / d.scale_for(True)).ravel()
    return band_of_replicates(replicates, base, bands.level, model=model, ratio=d.n / M, jacobian=base.jacobian_ * unit[:, None])


def _case(config, case):
    """Bands (B replicates of N runs) and a fitted base on a 1 s manoeuvre of ``case``."""
    t = np.arange(101) * 0.01
    delta = np.deg2rad(8.0 if case == "magic_formula" else 3.0) * np.sin(2 * np.pi * t / 1.0)
    speed = np.interp(t, [0.0, 0.3, 0.8, 1.0], [25.0, 25.0, 18.0, 18.0]) if case == "speed_profile" else None
    channels = ("psi_dot", "a_y") if case == "speed_profile" else STATES
    settings = Settings.from_config({**config, "wind": {**config["wind"], "Tc": 0.1}})  # ten gust modes over the second
    sim = AugmentedSimulator.drawn(settings, t, delta, 25.0, 16, np.random.default_rng(4), stride=4, channels=channels, speed=speed)
    structure = ModelStructure()
    if case == "magic_formula":
        structure = EFFECTS["sensor_scale_psi_dot"].augment(EFFECTS["tyre_saturation"].augment(structure, [0.9]), [1.05])
    index = np.arange(1, sim.output_time.size)
    C, K = len(channels), index.size
    # the spin threshold near the top of |beta|: a few realisations of some sets are left out
    spin = None
    if case == "magic_formula":
        pilot = sim.with_germs(type(sim.germs).draw(np.random.default_rng(5), 400, sim.germs.kle.shape[1])).simulate(THETA, structure)
        spin = float(np.quantile(np.abs(pilot[2]).max(axis=-1), 0.99))
    data = Compared(sim, None, index, np.full(C, 1e-6), spin, N, delta, 0.01, None, np.ones((2, C, K)), 1000, M)
    base = SimpleNamespace(theta_=THETA, structure_=structure, scale_=data.scale_for(True),
                           jacobian_=np.random.default_rng(6).standard_normal((2 * C * K, 3)))
    return NullBands(data, 7, B, 0.05), base


@pytest.mark.parametrize("case", ["speed_profile", "magic_formula", "exact"])
def test_the_footings_germ_sets_simulated_together_give_each_replicate_its_own_numbers(config, case, monkeypatch):
    """Along a speed profile (linear model, psi_dot and a_y) and with a Magic-Formula tyre (spun
    realisations excluded per set, a sensor gain the statistics apply) the sets share RK4 passes
    of at most 400 realisations (10 sets each); the exact discretisation simulates each set alone.
    Every array and number of the band equals the replicate-by-replicate band's exactly: a
    realisation's arithmetic (its ten gust modes' product included) must not depend on the
    others in its pass."""
    bands, base = _case(config, case)
    reference = _replicate_by_replicate(bands, base)
    monkeypatch.setattr(comparison, "_PASS_REALISATIONS", 400)
    sizes, simulate = [], AugmentedSimulator.simulate

    def counted(self, theta, s=ModelStructure(), germs=None):
        if germs is None:  # the model's (the data's replicates are simulated on germs given)
            sizes.append(self.germs.n)
        return simulate(self, theta, s, germs)

    monkeypatch.setattr(AugmentedSimulator, "simulate", counted)
    band = bands.footing(base)
    assert sizes == ([M] * B if case == "exact" else [400, 400, 400])
    for field in ("windows", "cell_scale", "max_null", "chi2_null"):
        assert np.array_equal(getattr(band, field), getattr(reference, field)), field
    assert (band.mean_square_null, band.chi2_null_sd, band.inflation) == (reference.mean_square_null, reference.chi2_null_sd,
                                                                          reference.inflation)


def test_the_footing_shares_the_null_bands_replicates(config, monkeypatch):
    """The footing's data replicates are the null band's (common random numbers): after the null
    band no data replicate is simulated again, and the footing is the same band whether the null
    band came first or not (its replicates are drawn from the null band's stream either way).
    Each band's mean of z^2 is its own: the null band compares with the fitted statistics, the
    footing with a fresh model per replicate on the wide scale."""
    bands, base = _case(config, "exact")
    base.statistics_ = StructureFit(bands.data.sim, bands.data.index, bands.data.noise, None).statistics(base.theta_, base.structure_)
    alone = bands.footing(base)
    bands, _ = _case(config, "exact")
    data_runs, simulate = [], AugmentedSimulator.simulate

    def counted(self, theta, s=ModelStructure(), germs=None):
        if germs is not None:  # the data's replicates (the model's sets are simulated on their own germs)
            data_runs.append(germs.n)
        return simulate(self, theta, s, germs)

    monkeypatch.setattr(AugmentedSimulator, "simulate", counted)
    null = bands.null(base)
    assert sum(data_runs) == B * N
    footing = bands.footing(base)
    assert sum(data_runs) == B * N  # none simulated again
    for field in ("max_null", "chi2_null", "cell_scale"):
        assert np.array_equal(getattr(footing, field), getattr(alone, field)), field
    assert footing.mean_square_null != null.mean_square_null
    assert bands.replicates(base) is bands.replicates(base)
    assert bands.replicates(base, key=1) is not bands.replicates(base)

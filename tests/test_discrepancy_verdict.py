"""The verdict's closing entry: `unrecognised` follows the named effects when the selection
stopped (its effect budget spent or nothing further justified) with the model still outside its
band by the null-calibrated gate."""

from types import SimpleNamespace

import numpy as np

from uqdrive.inference.discrepancy.band import NullBand, scan_windows
from uqdrive.inference.discrepancy.comparison import criterion
from uqdrive.inference.discrepancy.effectset import EffectSet
from uqdrive.inference.discrepancy.selection import Step
from uqdrive.inference.discrepancy.verdict import assemble_verdict
from uqdrive.vehicle.effects import ModelStructure

K = 40
THETA = np.array([1.0, 0.2, 1.55, 0.2, -400.0, 400.0])


def _fit(z, names=()):
    """A fit stand-in whose intervals are 0.1 -+ 0.01 sqrt(inflation) (a Gauss-Newton variance times the inflation)."""
    eff = EffectSet(names) if names else None
    flat = lambda inflation=1.0: {p: [0.1, 0.1 - 0.01 * np.sqrt(inflation), 0.1 + 0.01 * np.sqrt(inflation)] for p in eff.parameters} if eff else {}  # noqa: E731
    return SimpleNamespace(z_=z, theta_=THETA, chi2_=float(np.sum(z**2)), success_=True, structure_=ModelStructure(), effect=eff,
                           parameter_names=("x",) * (6 + len(flat())), effect_intervals=flat)


def _verdict(rest, max_effects, whole=False):
    """A baseline with a rough (not smooth: the catch-all cannot absorb it) gap of 3 band units,
    one named effect leaving ``rest`` (2, 4, K) on top of null-like noise."""
    rng = np.random.default_rng(0)
    band = NullBand.from_replicates(rng.standard_normal((300, 2, 4, K)), scan_windows(K))
    base = _fit(3.0 * rng.standard_normal((2, 4, K)))
    aug = _fit(rng.standard_normal((2, 4, K)) + rest, ("actuator_lag",))
    step = Step("actuator_lag", aug, band, "own", explains=False, gap_after=0.5)
    finder = SimpleNamespace(augmented_=aug, augmented_band_=band, steps_=[step], fits_={"actuator_lag": aug}, unresolved_={}, removed_=[], rejected_=[],
                             screening_={}, max_effects=max_effects, settings=SimpleNamespace(spin=SimpleNamespace(policy="exclude")), spun_=np.array([], int),
                             samples_used_=100, noise_variance_=np.ones(4), channels_=("psi", "psi_dot", "beta", "y"), untestable_=[], speed_profile_=None, model_samples=400, interpolation_="linear", level=0.01,
                             time_=np.arange(1, K + 1) * 0.1, band_=band,
                             comparison_=SimpleNamespace(criterion=criterion, chi2=lambda f: f.chi2_, band_of=lambda f: band))
    ctx = SimpleNamespace(n=100)
    verdict = assemble_verdict(finder, base, band, band.max_statistic(base.z_), True, ctx)
    return (verdict, aug, band) if whole else [e["effect"] for e in verdict["effects"]]


def test_unrecognised_follows_when_the_selection_ends_with_the_model_outside_its_band():
    rest = np.zeros((2, 4, K))
    rest[0, 3, 10:20] = 4.0  # a local misfit of 4 band units: the scan crosses, chi2 rises by 160 (> 2 null sd ~ 50)
    assert _verdict(rest, max_effects=1) == ["actuator_lag", "unrecognised"]
    # below the budget, the selection stopped because no candidate explains the rest: still unexplained
    assert _verdict(rest, max_effects=3) == ["actuator_lag", "unrecognised"]
    # inside the band, at the budget or below it: nothing is left
    assert _verdict(np.zeros((2, 4, K)), max_effects=1) == ["actuator_lag"]
    assert _verdict(np.zeros((2, 4, K)), max_effects=3) == ["actuator_lag"]


def test_a_scan_crossing_without_excess_misfit_leaves_nothing_unexplained():
    """The gate needs both: a single cell beyond the threshold whose chi2 excess stays within two null
    sd is the scan's own false alarm, not a rest (the rule is the gate, not the scan alone)."""
    rest = np.zeros((2, 4, K))
    rest[0, 3, 12] = 6.0  # one cell: the scan crosses (6 > threshold 3.85), chi2 rises by ~36 < 2 null sd (~50)
    names = _verdict(rest, max_effects=3)
    rng = np.random.default_rng(0)
    band = NullBand.from_replicates(rng.standard_normal((300, 2, 4, K)), scan_windows(K))
    rng.standard_normal((2, 4, K))
    z = rng.standard_normal((2, 4, K)) + rest
    assert band.max_statistic(z) > band.threshold and not band.gate(z)  # the premise: a crossing, no excess
    assert names == ["actuator_lag"]


def test_intervals_widen_by_the_lack_of_fit_of_a_model_that_leaves_a_rest():
    """A named effect whose model stays outside its band (a rest of 4 band units over 10 cells)
    reports its interval widened by sqrt(chi2 / null chi2), the Birge ratio, on top of the null's
    inflation; a model inside its band (chi2 below its null expectation) keeps the null's interval.
    Without the factor the half-width would be 0.01 sqrt(inflation) in both."""
    rest = np.zeros((2, 4, K))
    rest[0, 3, 10:20] = 4.0
    verdict, aug, band = _verdict(rest, max_effects=3, whole=True)
    ratio = aug.chi2_ / (band.mean_square_null * aug.z_.size)
    assert ratio > 1.3  # the premise: a lack of fit worth a wider interval
    est, lo, hi = verdict["effects"][0]["parameters"]["T"]
    np.testing.assert_allclose((hi - lo) / 2, 0.01 * np.sqrt(band.inflation * ratio), rtol=1e-9)
    assert verdict["evidence"]["lack_of_fit"] == round(ratio, 3)
    verdict, aug, band = _verdict(np.zeros((2, 4, K)), max_effects=3, whole=True)
    assert aug.chi2_ < band.mean_square_null * aug.z_.size  # the premise (ratio 0.995 with this seed)
    est, lo, hi = verdict["effects"][0]["parameters"]["T"]
    np.testing.assert_allclose((hi - lo) / 2, 0.01 * np.sqrt(band.inflation), rtol=1e-9)
    assert verdict["evidence"]["lack_of_fit"] == 1.0

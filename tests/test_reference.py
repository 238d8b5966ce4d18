import pytest

from uqdrive.vehicle.montecarlo import simulate_ensemble, wind_kle
from uqdrive.vehicle.reference import solve_realisations
from uqdrive.settings import Settings


def test_reference_lst_is_odd_in_the_steering_without_wind(cfg):
    """The LST is linear in delta: with no wind, inverted steering (5.7) negates the response."""
    cfg["uncertainty"]["F_w_mean"] = {"low": 0.0, "high": 0.0}
    cfg["wind"]["sigma"] = 0.0
    kle = wind_kle(Settings.from_config(cfg))
    runs = {
        steer: solve_realisations(Settings.from_config(cfg), simulate_ensemble(Settings.from_config(cfg), "lst", steer, samples=2, kle=kle), kle, [1], "DOP853", 1e-10, 1e-12)
        for steer in ("normal", "inverted")
    }
    assert runs["inverted"] == pytest.approx(-runs["normal"], abs=1e-9)


def test_reference_matches_the_ensemble_for_the_nlst(config):
    ds = simulate_ensemble(Settings.from_config(config), "nlst", samples=2)
    ref = solve_realisations(Settings.from_config(config), ds, wind_kle(Settings.from_config(config)), [0, 1], "DOP853", 1e-9, 1e-11)
    assert ref[:, :, 3] == pytest.approx(ds["y"].values, rel=1e-4, abs=1e-6)

import numpy as np
import pytest

from uqdrive.config import load_config
from uqdrive.identification_study import EXPERIMENTS, experiment_plan, measured_data_sets, run_experiment, true_theta, w2_scores
from uqdrive.identification_tables import table_rows, table_scorecard_rows, THESIS_TABLE_6_2, THESIS_TABLE_6_3
from uqdrive.montecarlo import simulate_ensemble
from uqdrive.rng import rng_stream
from uqdrive.statistics import ensemble_statistics, noise_statistics

from conftest import REPO


@pytest.fixture(scope="module")
def small():
    cfg = load_config(REPO / "config" / "test.yaml")
    cfg["identification"]["runs"] = 1
    return cfg


@pytest.fixture(scope="module")
def data(small):
    stats = {}
    for model in ("lst", "nlst"):
        for steer in ("normal", "inverted"):
            stats[f"{model}_{steer}"] = ensemble_statistics(simulate_ensemble(small, model, steer), "exclude")
        e = simulate_ensemble(small, model)
        stats[f"noise_{model}"] = noise_statistics(e, small["noise"]["levels"], [rng_stream(1, "noise", i) for i in range(2)])
    return measured_data_sets(small, stats)


def test_w2_of_the_truth_is_zero(config):
    assert w2_scores(true_theta(config), config) == pytest.approx(np.zeros(3), abs=1e-12)


def test_every_experiment_has_a_plan(small):
    for name in EXPERIMENTS:
        tasks, dev, mdev, run_data = experiment_plan(small, name)
        assert len(dev) == len(mdev) == len(run_data) and tasks
    with pytest.raises(ValueError, match="unknown experiment"):
        experiment_plan(small, "weather")


@pytest.mark.parametrize("name", ["basic", "noise"])
def test_experiments_run_and_tables(small, data, name):
    tasks, dev, mdev, run_data = experiment_plan(small, name)
    ds = run_experiment(small, name, data, tasks, dev, mdev, np.random.default_rng(0), run_data)
    assert ds["theta"].shape == (len(dev), len(tasks), 6)
    assert np.all(np.isfinite(ds["w2"].sel(estimate="LST-STD")))
    rows = table_rows(ds, THESIS_TABLE_6_2)
    assert rows[0]["estimate"] == "LST-STD" and rows[0]["thesis mu"] == "N(0.998, 0.202)"
    if name == "basic":
        assert len(table_scorecard_rows(ds, ds)) >= 4
        assert THESIS_TABLE_6_3["NLST-STD"][0] == 0.796

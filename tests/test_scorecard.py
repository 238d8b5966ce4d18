import csv

from uqdrive.vehicle.montecarlo import kle_from_config
from uqdrive.studies.scorecard import COLUMNS, compare, foundation_rows, read_scorecard, write_scorecard


def test_foundation_rows_pass(config):
    rows = foundation_rows(config, kle_from_config(config))
    assert len(rows) == 5
    assert all(r.status == "pass" for r in rows), rows


def test_compare_fails_outside_tolerance():
    assert compare("x", "s", 1.0, 1.02, 0.01).status == "fail"
    assert compare("x", "s", 1.0, float("nan"), 0.01).status == "fail"


def test_csv_columns_and_roundtrip(config, tmp_path):
    rows = foundation_rows(config, kle_from_config(config))
    path = tmp_path / "scorecard.csv"
    write_scorecard(rows, path)
    with open(path) as fh:
        assert tuple(next(csv.reader(fh))) == COLUMNS
    assert [r.quantity for r in read_scorecard(path)] == [r.quantity for r in rows]

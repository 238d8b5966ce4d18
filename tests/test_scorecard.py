import csv

import pytest

from uqdrive.vehicle.montecarlo import wind_kle
from uqdrive.studies.scorecard import COLUMNS, KNOWN_DEVIATIONS, compare, foundation_rows, read_scorecard, write_scorecard
from uqdrive.settings import Settings


def test_foundation_rows_pass(config):
    rows = foundation_rows(config, wind_kle(Settings.from_config(config)))
    assert len(rows) == 11  # 4 gains, the mode count, 5 eigenvalues, the captured share
    assert all(r.status == "pass" and r.reason == "" for r in rows), rows


def test_compare_fails_outside_tolerance():
    assert compare("x", "s", 1.0, 1.02, 0.01).status == "fail"
    assert compare("x", "s", 1.0, 1.01, 0.01).status == "pass"
    assert compare("x", "s", 1.0, 0.99, 0.01).status == "pass"
    assert compare("x", "s", 1.0, 0.98, 0.01).status == "fail"
    assert compare("x", "s", 1.0, float("nan"), 0.01).status == "fail"
    assert compare("x", "s", 1.0, float("nan"), 0.01).reason == "not understood"


def test_compare_deviates_only_for_a_registered_row_whose_condition_holds():
    dev = KNOWN_DEVIATIONS["slqr_grid"]
    row = compare("SLQR gain K[1]", "thesis eq. (6.2)", -1.81, -1.5, 0.005, deviation="slqr_grid")
    assert (row.status, row.reason, row.evidence) == ("deviates", dev.reason, dev.evidence)
    inside = compare("SLQR gain K[1]", "thesis eq. (6.2)", -1.81, -1.806, 0.005, deviation="slqr_grid")
    assert (inside.status, inside.reason) == ("pass", "")
    held_not = compare("SLQR gain K[1]", "thesis eq. (6.2)", -1.81, -1.5, 0.005, deviation="slqr_grid", holds=False)
    assert held_not.status == "fail" and held_not.reason.startswith("not understood: deviation 'slqr_grid'") and dev.when in held_not.reason
    nan = compare("SLQR gain K[1]", "thesis eq. (6.2)", -1.81, float("nan"), 0.005, deviation="slqr_grid")
    assert nan.status == "fail"
    with pytest.raises(ValueError, match="not registered"):
        compare("LQR gain K[1] (mean LST)", "thesis eq. (6.1)", -1.85, -1.5, 0.005, deviation="slqr_grid")
    with pytest.raises(KeyError):
        compare("SLQR gain K[1]", "thesis eq. (6.2)", -1.81, -1.5, 0.005, deviation="no such deviation")


def test_csv_columns_and_roundtrip(config, tmp_path):
    rows = foundation_rows(config, wind_kle(Settings.from_config(config)))
    rows.append(compare("SLQR gain K[1]", "thesis eq. (6.2)", -1.81, -1.5, 0.005, deviation="slqr_grid"))
    path = tmp_path / "scorecard.csv"
    write_scorecard(rows, path)
    with open(path) as fh:
        header = tuple(next(csv.reader(fh)))
    assert header == COLUMNS
    assert header[:6] == ("quantity", "source", "published", "reproduced", "tolerance", "status")  # extended, never renamed
    back = read_scorecard(path)
    assert [r.quantity for r in back] == [r.quantity for r in rows]
    assert [(r.status, r.reason, r.evidence) for r in back] == [(r.status, r.reason, r.evidence) for r in rows]
    assert [r.published for r in back] == pytest.approx([r.published for r in rows], rel=1e-6)


def test_read_scorecard_without_the_new_columns(tmp_path):
    path = tmp_path / "old.csv"
    path.write_text("quantity,source,published,reproduced,tolerance,status\nx,s,1,1.5,0.1,fail\n")
    (row,) = read_scorecard(path)
    assert (row.quantity, row.published, row.reproduced, row.tolerance, row.status, row.reason, row.evidence) == ("x", 1.0, 1.5, 0.1, "fail", "", "")

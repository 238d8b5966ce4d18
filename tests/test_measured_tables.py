"""The docs' tables of measurements are written from their committed records, with what the code
defines computed at the build: the rules' declared resources, the binomial bands, the runs' own
sampling error."""

import json
import re
import math
import sys
from pathlib import Path


ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "docs"))
import measured_tables  # noqa: E402
import reproduction_tables  # noqa: E402,F401  (measured_tables.reproduction_tables)

sys.path.pop(0)


def test_every_record_row_is_a_table_row_and_the_sampling_errors_are_computed():
    rows = [json.loads(l) for l in (ROOT / "docs" / "measurements" / "bench_channels.jsonl").read_text().splitlines() if l.strip()]
    table = measured_tables.channels_table()
    assert table.count("\n| ") == len(rows)  # one line per record (the header opens the text, its rule is "|---")
    assert all(f"| {r['set']} | {r['runs']} | {r['mu_mean_error']:.4f} |" in table for r in rows)
    sigma = measured_tables._truth_std()
    assert f"{sigma / math.sqrt(10):.2g} (10)" in table  # sigma / sqrt(n), not a copied number


def test_declared_resources_are_read_from_the_rules(tmp_path, monkeypatch):
    rules, _ = measured_tables.resources_tables(ROOT)
    declared = measured_tables._tool(ROOT, "rule_resources").declared()
    record = json.loads((ROOT / "docs" / "measurements" / "rule_resources.json").read_text())["full"]["rules"]
    for rule, m in record.items():
        mem, runtime = declared[rule]
        assert f"| {rule} | {m['jobs']} | {m['max_rss']:.0f} | {mem:.0f} |" in rules and f"| {runtime:.0f} min |" in rules


def test_the_coverage_bands_follow_the_replicate_count():
    from uqdrive.studies.identification import binomial_band

    table = measured_tables.coverage_table()
    lo, hi = binomial_band(200, 0.95, 0.01)
    assert f"| 300 | mu mean | 0.950 | [{lo:.3f}, {hi:.3f}] |" in table
    lo, hi = binomial_band(100, 0.95, 0.01)
    assert f"| 1000 | mu mean | 0.940 | [{lo:.3f}, {hi:.3f}] |" in table
    assert "average 0.94" in table


# Versions of pytest and xdist named where the page explains the pin: inputs, not measurements.
VERSIONS_ALLOWED = {"9.2", "9.1.1", "3.8"}
MEASURED = re.compile(r"(?<![\w.])(\d+\.\d+(?:\.\d+)*(?: %|x\b)?|\d+(?: %|x\b))")


def _prose(text: str) -> str:
    """The page without fenced blocks, inline code and substitutions: what a reader sees typed."""
    text = re.sub(r"^```.*?^```", "", text, flags=re.S | re.M)
    text = re.sub(r"\{\{.*?\}\}", "", text)
    return re.sub(r"`[^`]*`", "", text)


def test_the_benchmarks_page_types_no_measured_number():
    """Every decimal, percentage or speed-up on the benchmarks page comes from a record: a number
    typed back into its text fails here."""
    page = (ROOT / "docs" / "benchmarks.md").read_text()
    found = [m for m in MEASURED.findall(_prose(page)) if m not in VERSIONS_ALLOWED]
    assert found == []
    assert MEASURED.findall(_prose("took 92.2 s, `0.5` and {{ x }}, 48 % of it, 2.7x faster")) == ["92.2", "48 %", "2.7x"]


def test_the_benchmark_ratios_are_computed_from_the_records():
    subs = measured_tables.substitutions(ROOT)
    rec = json.loads((ROOT / "docs" / "measurements" / "benchmarks_discover.json").read_text())
    assert subs["bench_disc_ratio"] == f"{rec['wall_s'] / rec['budget_s']:.2f}"
    page = (ROOT / "docs" / "benchmarks.md").read_text()
    names = set(re.findall(r"\{\{ (\w+) \}\}", page))
    assert names <= set(subs)  # every substitution the page uses is defined
    chassis = json.loads((ROOT / "docs" / "measurements" / "benchmarks_chassis.json").read_text())["rows"]
    table = measured_tables.benchmark_tables.chassis_table()
    assert all(f"| {r['one_by_one_s'] / r['many_s']:.2f} |" in table for r in chassis)
    for name in measured_tables.benchmark_tables.TABLES:
        assert f"api/generated/{name}.md" in page


# Published seed values the reproduction page may type (each must be a published value of the code
# or of the scorecard record's `published` column); every other decimal there comes from the build.
REPRODUCTION_ALLOWED: set[str] = set()
DECIMAL = re.compile(r"(?<![\w.])-?\d+\.\d+(?![\w.])")
# Labels of the seeds' tables, figures, sections and equations: names, not numbers.
LABEL = re.compile(r"\b(?:Tables?|Figs?\.?|Figures?|sec\.)\s+[A-Z]?\d+(?:\.\d+)*(?:\s*(?:-|,|/|and)\s*[A-Z]?\d+(?:\.\d+)*)*"
                   r"|\(\d+\.\d+[a-z]?\)")


def test_the_reproduction_page_types_no_reproduced_number():
    """Every decimal the reproduction page shows comes from the scorecard record or the config at
    the build: one typed back into its text fails here."""
    import csv

    page = (ROOT / "docs" / "reproduction.md").read_text()
    prose = LABEL.sub("", re.sub(r"\{\w+\}`[^`]*`", "", _prose(page)))
    assert [d for d in DECIMAL.findall(prose) if d not in REPRODUCTION_ALLOWED] == []
    assert DECIMAL.findall(LABEL.sub("", "Table 6.2 and (5.25), Figs 6.7-6.15, B.1-B.13 give N(0.793, 0.188)")) == ["0.793", "0.188"]
    from uqdrive.studies import scorecard, tables

    with open(ROOT / "docs" / "measurements" / "scorecard.csv", newline="") as fh:
        published = {float(r["published"]) for r in csv.DictReader(fh)}
    published |= {float(v) for t in (tables.THESIS_TABLE_6_2, tables.THESIS_TABLE_6_3) for row in t.values() for v in row}
    published |= {float(v) for v in scorecard.PAPER.values()} | set(scorecard.THESIS_LQR_GAIN) | set(scorecard.THESIS_SLQR_GAIN)
    assert all(float(v) in published for v in REPRODUCTION_ALLOWED)


def test_the_reproduction_page_quotes_scorecard_rows_by_quantity(tmp_path):
    """The page's substitutions are defined and read the record's rows; a row missing from the
    record stops the build naming its quantity."""
    import csv
    import pytest

    tables = measured_tables.reproduction_tables
    page = (ROOT / "docs" / "reproduction.md").read_text()
    assert set(re.findall(r"\{\{ (\w+) \}\}", page)) <= set(measured_tables.substitutions(ROOT))
    assert all(f"api/generated/{name}.md" in page for name in tables.TABLES)
    rows = tables.scorecard()
    quantity = "NLST-STD mu mean (thesis Table 6.2, without the wind yaw moment)"
    rows[quantity] = dict(rows[quantity], reproduced="0.7123")
    assert tables.substitutions(rows)["rep_nlst_mc0_mu"] == "0.71"  # read from the row, not typed
    unit_free = "NLST-STD mu mean (thesis Table 6.2, unit-free residuals)"
    rows[unit_free] = dict(rows[unit_free], reproduced="0.4321")
    assert "| NLST-STD | unit-free | 0.432 |" in tables.table_6_2(rows)
    del rows[quantity]
    with pytest.raises(tables.MissingScorecardRow, match=re.escape(quantity)):
        tables.substitutions(rows)

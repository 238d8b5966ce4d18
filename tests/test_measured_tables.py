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

"""The report without running the DAG: every report() output has a category and a caption that
names its seed figure; captions and the landing page render; report_summary's tables."""

import csv
import importlib.util
import re
from dataclasses import dataclass
from types import SimpleNamespace

import pytest
import yaml
from docutils.core import publish_parts
from jinja2 import Environment, StrictUndefined

from conftest import REPO

RULES = sorted((REPO / "workflow" / "rules").glob("*.smk")) + [REPO / "Snakefile", REPO / "workflow" / "Snakefile"]
REPORT_DIR = REPO / "workflow" / "report"
#: A caption names the seed figure, table or equation it regenerates ("Thesis **Fig. 6.6**",
#: "Paper **Figs. 7 and 8**", "Thesis **Eqs. (6.1) and (6.2)**") or says that it is uqdrive's own.
SEED = re.compile(r"\b(Thesis|Paper) \*\*(Figs?|Tables?|Eqs?)\.? [0-9A-B(]")
OWN = re.compile(r"uqdrive's own")


def report_calls():
    """(file, argument text) of every report(...) call in the rules, parentheses balanced."""
    calls = []
    for path in RULES:
        text = path.read_text()
        for match in re.finditer(r"\breport\(", text):
            depth, i = 1, match.end()
            while depth:
                depth += {"(": 1, ")": -1}.get(text[i], 0)
                i += 1
            calls.append((path.name, text[match.end():i - 1]))
    return calls


def caption_files():
    names = {re.search(r'caption="\.\./report/([^"]+)"', args).group(1) for _, args in report_calls()}
    return sorted(REPORT_DIR / name for name in names)


def test_every_report_output_has_a_category_and_an_existing_caption():
    calls = report_calls()
    assert len(calls) > 30
    for where, args in calls:
        assert re.search(r"\bcategory=", args), f"{where}: report({args[:60]}...) without a category"
        caption = re.search(r'caption="([^"]+)"', args)
        assert caption, f"{where}: report({args[:60]}...) without a caption"
        assert (REPO / "workflow" / "rules" / caption.group(1)).resolve().is_file(), f"{where}: {caption.group(1)} missing"


def test_every_caption_names_its_seed_figure_or_says_it_is_uqdrives_own():
    for path in caption_files():
        text = path.read_text()
        assert SEED.search(text) or OWN.search(text), f"{path.name} names no seed figure and does not say it is uqdrive's own"


def test_every_caption_file_is_used():
    used = {p.name for p in caption_files()} | {"workflow.rst"}
    assert {p.name for p in REPORT_DIR.glob("*.rst")} <= used


# --- rendering: Jinja as Snakemake runs it (but strict about undefined names), then docutils ----

@dataclass(frozen=True, order=True)
class Category:
    """As snakemake.report.Category: a named, sortable key of ``categories``."""
    name: str


class _Files:
    """``snakemake.output`` of a caption: any name or index is a small CSV table."""

    def __init__(self, path):
        self._path = path

    def __getattr__(self, name):
        return self._path

    def __getitem__(self, index):
        return self._path


def _context(config, table):
    params = SimpleNamespace(model="lst", index=0, provenance={"config": "config/test.yaml"}, file="config/sweeps/s.yaml",
                             sweep=SimpleNamespace(keys=["noise.levels"], base_path="config/test.yaml", description="A sweep."))
    snakemake = SimpleNamespace(config=config, wildcards=SimpleNamespace(number="1", n="1", sweep="s"), params=params, output=_Files(table))
    records = [SimpleNamespace(target=name, path=table, name=name, labels=labels) for name, labels in
               [("scorecard_counts.csv", {"table": "counts"}), ("headline.csv", None), ("discrepancy_verdicts.csv", None),
                ("environment.csv", None), ("scorecard.html", None), ("table_6_2.csv", None), ("fig_6_6.png", {"figure": "Fig. 6.6"}),
                ("fig_A12.png", {"model": "NLST"}), ("paper_fig_4.png", None)]]
    categories = {Category("Scorecard"): {Category("Other"): records[:5]}, Category("Thesis 6.1 Measured data"): {Category("Other"): records[5:]}}
    return snakemake, categories, records


def _render(path, snakemake, categories, files):
    """The HTML Snakemake would make of an .rst file, with its link targets (as in
    snakemake.report.auto_report: one per category and one per file)."""
    links = "\n\n" + "\n".join([".. _Scorecard: javascript:void(0)"] + [f".. _{f.target}: javascript:void(0)" for f in files]
                               + [f".. _{c.name}: javascript:void(0)" for c in categories if c.name != "Scorecard"])
    env = Environment(trim_blocks=True, lstrip_blocks=True, undefined=StrictUndefined)
    text = env.from_string(path.read_text() + links).render(snakemake=snakemake, categories=categories, files=files)
    return publish_parts(text, writer="html")["html_body"]


@pytest.mark.parametrize("config_file", ["config.yaml", "test.yaml"])
def test_captions_and_landing_page_render_without_errors(config_file, tmp_path):
    table = tmp_path / "t.csv"
    table.write_text("a,b\n1,2\n3,4\n")
    config = yaml.safe_load((REPO / "config" / config_file).read_text())
    snakemake, categories, files = _context(config, str(table))
    for path in caption_files() + [REPORT_DIR / "workflow.rst"]:
        html = _render(path, snakemake, categories, files)
        assert "system-message" not in html, f"{path.name}: {re.sub('<[^>]+>', ' ', html[html.find('system-message'):][:300])}"
        if ":file:" in path.read_text():
            assert "<td>3</td>" in html, f"{path.name} does not show its table"
    landing = _render(REPORT_DIR / "workflow.rst", snakemake, categories, files)
    assert "Fig. 6.6" in landing and "Fig. A.12" in landing and "paper Fig. 4" in landing
    assert str(config["seed"]) in landing


def test_landing_page_renders_for_a_partial_run():
    """Before rule report_summary has run, the landing page leaves its tables out, without errors."""
    config = yaml.safe_load((REPO / "config" / "test.yaml").read_text())
    snakemake, _, _ = _context(config, "missing.csv")
    html = _render(REPORT_DIR / "workflow.rst", snakemake, {}, [])
    assert "system-message" not in html and "<table" not in html


# --- rule report_summary's tables ----------------------------------------------------------

@pytest.fixture(scope="module")
def summary():
    spec = importlib.util.spec_from_file_location("report_summary", REPO / "workflow" / "scripts" / "report_summary.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)  # not __main__: nothing runs
    return module


CARD = [
    {"quantity": "LQR gain K[1] (mean LST)", "source": "thesis eq. (6.1)", "published": "-1.85", "reproduced": "-1.853", "tolerance": "0.005", "status": "pass"},
    {"quantity": "NLST-STD mu mean (thesis Table 6.2, unit-free residuals)", "source": "thesis Table 6.2, unit-free residuals",
     "published": "0.797", "reproduced": "0.80", "tolerance": "0.03", "status": "pass"},
    {"quantity": "LST-STD l_f mean (thesis Table 6.2)", "source": "thesis Table 6.2", "published": "1.542", "reproduced": "1.62",
     "tolerance": "0.02", "status": "deviates"},
    {"quantity": "KLE eigenpairs kept", "source": "thesis sec. 7.3, Fig. 7.1", "published": "5", "reproduced": "5", "tolerance": "0", "status": "pass"},
    {"quantity": "K_p offset", "source": "paper eq. (28)", "published": "67.55", "reproduced": "67.5", "tolerance": "0.1", "status": "pass"},
    {"quantity": "discrepancy: false alarms on null cases (share)", "source": "uqdrive check", "published": "0", "reproduced": "0.5",
     "tolerance": "0.2", "status": "fail"},
]


def test_sections_and_counts(summary):
    assert [summary.section(r["source"]) for r in CARD] == ["thesis ch. 6", "thesis ch. 6", "thesis ch. 6", "thesis ch. 7", "paper",
                                                            "uqdrive (past the seeds)"]
    counts = summary.count_rows(CARD + [dict(CARD[0], status="odd")])
    assert [c["seed section"] for c in counts] == ["thesis ch. 6", "thesis ch. 7", "paper", "uqdrive (past the seeds)", "all"]
    assert counts[0] == {"seed section": "thesis ch. 6", "pass": 2, "deviates": 1, "fail": 0, "odd": 1, "rows": 4}
    assert counts[-1]["rows"] == 7 and counts[-1]["fail"] == 1


def test_headline_puts_table_6_2_beside_the_thesis(summary):
    rows = summary.headline_rows(CARD)
    assert [(r["result"], r["variant"], r["published"], r["uqdrive"]) for r in rows] == [
        ("NLST-STD mu mean", "unit-free residuals", "0.797", "0.80"), ("LST-STD l_f mean", "as printed (SI residuals)", "1.542", "1.62"),
        ("discrepancy: false alarms on null cases (share)", "uqdrive check", "0", "0.5")]
    assert summary.headline_rows(CARD[:1])[0]["result"].startswith("(no Table 6.2")


def test_environment_and_scorecard_page(summary):
    card = [dict(r, config="config/test.yaml", config_hash="abc", seed="7", uqdrive_version="0.1.0") for r in CARD]
    rows = summary.environment_rows({"python": "3.11.7", "numpy": "2.0"}, card)
    assert rows == [{"name": "python", "version": "3.11.7"}, {"name": "numpy", "version": "2.0"}, {"name": "config", "version": "config/test.yaml"},
                    {"name": "config_hash", "version": "abc"}, {"name": "seed", "version": "7"}]
    page = summary.scorecard_page(card)
    assert page.count("<h2>") == 4 and 'class="deviates"' in page and "config_hash abc" in page
    assert page.index("thesis ch. 6") < page.index("paper") < page.index("uqdrive (past the seeds)")


def test_package_versions_cover_what_the_issue_names():
    """The environment table is made from scorecard.smk's PACKAGE_VERSIONS: python, uqdrive and
    every package uqdrive requires, which include the ones the reproduction rests on."""
    from importlib import metadata
    required = {re.match(r"[A-Za-z0-9_.-]+", r).group().lower() for r in metadata.requires("uqdrive") if "extra ==" not in r}
    assert {"numpy", "scipy", "xarray", "netcdf4", "matplotlib", "emcee", "snakemake"} <= required
    assert "PACKAGE_VERSIONS" in (REPO / "workflow" / "rules" / "scorecard.smk").read_text()


def test_report_summary_reads_the_scorecard_columns(summary, tmp_path):
    path = tmp_path / "card.csv"
    with open(path, "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(CARD[0]))
        writer.writeheader()
        writer.writerows(CARD)
    assert summary.read_rows(path) == CARD
    assert summary.verdict_rows([{"case": "x", "mu_mean_before": "1.0197260321339514"}])[0]["mu mean before"] == "1.020"


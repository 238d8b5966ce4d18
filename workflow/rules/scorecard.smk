# The scorecard: every published number uqdrive reproduces, one CSV row each.
import platform
import re
from importlib import metadata


rule scorecard_foundation:
    input:
        src("studies.scorecard", "control.lqr", "vehicle.single_track", "vehicle.uncertainty", "vehicle.montecarlo"),
    output:
        f"{OUT}/scorecard/foundation.csv",
    params:
        **reads("vehicle", "tyre", "uncertainty.mu.mean", "uncertainty.m_load.mean", "uncertainty.l_f.mean", "control.Q_diag", "control.R",
                "wind.Tc", "wind.kle_quadrature", "wind.kle_truncation", "time.t_end"),
    threads: 1
    resources:
        mem_mb=1000,
        runtime=5,
    group: "summary"
    log:
        f"{OUT}/logs/scorecard_foundation.log",
    benchmark:
        f"{OUT}/benchmarks/scorecard_foundation/scorecard_foundation.tsv",
    conda:
        "../envs/uqdrive.yaml"
    script:
        "../scripts/scorecard_foundation.py"


rule scorecard:
    input:
        src("studies.scorecard"),
        parts=expand(f"{OUT}/scorecard/{{part}}.csv", part=SCORECARD_PARTS),
    output:
        f"{OUT}/scorecard/merged.csv",
    threads: 1
    resources:
        mem_mb=1000,
        runtime=2,
    group: "summary"
    log:
        f"{OUT}/logs/scorecard.log",
    benchmark:
        f"{OUT}/benchmarks/scorecard/scorecard.tsv",
    conda:
        "../envs/uqdrive.yaml"
    script:
        "../scripts/scorecard_merge.py"


rule scorecard_provenance:
    input:
        src("io"),
        merged=f"{OUT}/scorecard/merged.csv",
    output:
        report(f"{OUT}/scorecard.csv", caption="../report/scorecard.rst", category="Scorecard", labels={"table": "scorecard: every published number"}),
    params:
        provenance=PROVENANCE,
    threads: 1
    resources:
        mem_mb=1000,
        runtime=2,
    group: "summary"
    log:
        f"{OUT}/logs/scorecard_provenance.log",
    benchmark:
        f"{OUT}/benchmarks/scorecard_provenance/scorecard_provenance.tsv",
    conda:
        "../envs/uqdrive.yaml"
    script:
        "../scripts/scorecard_provenance.py"


#: Python, uqdrive and every package uqdrive requires, at the versions this run imports; a param
#: of report_summary, so that an upgrade rewrites the report's environment table.
PACKAGE_VERSIONS = {"python": platform.python_version(), "uqdrive": metadata.version("uqdrive")} | {
    name: metadata.version(name) for name in sorted({re.match(r"[A-Za-z0-9_.-]+", r).group() for r in metadata.requires("uqdrive") if "extra ==" not in r})}


rule report_summary:
    # The tables of the report's landing page (workflow/report/workflow.rst), the scorecard page.
    input:
        scorecard=f"{OUT}/scorecard.csv",
        verdicts=f"{DISC}/benchmark_summary.csv",
    output:
        counts=report(f"{OUT}/tables/scorecard_counts.csv", caption="../report/scorecard_counts.rst", category="Scorecard", labels={"table": "counts per seed section"}),
        headline=report(f"{OUT}/tables/headline.csv", caption="../report/headline.rst", category="Scorecard", labels={"table": "headline: Table 6.2 and the discrepancy checks"}),
        verdicts=report(f"{OUT}/tables/discrepancy_verdicts.csv", caption="../report/discrepancy_verdicts.rst", category="Scorecard", labels={"table": "discrepancy verdicts"}),
        environment=report(f"{OUT}/tables/environment.csv", caption="../report/environment.rst", category="Scorecard", labels={"table": "package versions"}),
        page=report(f"{OUT}/tables/scorecard.html", caption="../report/scorecard_page.rst", category="Scorecard", labels={"table": "scorecard by seed section"}),
    params:
        versions=PACKAGE_VERSIONS,
    threads: 1
    resources:
        mem_mb=1000,
        runtime=2,
    group: "summary"
    log:
        f"{OUT}/logs/report_summary.log",
    benchmark:
        f"{OUT}/benchmarks/report_summary/report_summary.tsv",
    conda:
        "../envs/uqdrive.yaml"
    script:
        "../scripts/report_summary.py"


# `all` builds FIGURES and `reported` shows those that exist: the landing page's tables join them.
FIGURES += [f"{OUT}/tables/{name}" for name in ("scorecard_counts.csv", "headline.csv", "discrepancy_verdicts.csv", "environment.csv", "scorecard.html")]

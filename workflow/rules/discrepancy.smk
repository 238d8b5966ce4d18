# The discrepancy workflow (past the thesis): `uqdrive discover` on the configured measured files
# and on the hidden-effect benchmark, whose labels live apart from the ensembles discover reads.

from uqdrive.studies.hidden_effects import benchmark_cases as _benchmark_cases

_BENCH = config["discrepancy"]["benchmark"]
_ALL_CASES = [c.name for c in _benchmark_cases(config, samples=_BENCH["samples"])]
DISCREPANCY_CASES = _ALL_CASES if _BENCH["cases"] == "all" else list(_BENCH["cases"])
DISCREPANCY_MEASURED = dict(config["discrepancy"].get("measured", {}))
DISC = f"{OUT}/discrepancy"
#: What the reality generator and `discover` read: the car, its priors, the wind, the spin policy.
DISC_KEYS = ("seed", "vehicle", "tyre", "uncertainty", "wind", "time", "steering", "montecarlo", "discrepancy")

#: The benchmark case on the thesis' data, whose bands and localisation the report shows
#: (rule discrepancy_thesis_figures).
THESIS_CASE = "thesis_nlst"
#: The benchmark cases whose discover folders get bands.png and localisation.png: the others'
#: verdicts are what the summary reads, and drawing their figures would cost each job
#: matplotlib's import and two figures nobody reads.
FIGURE_CASES = (THESIS_CASE,)

wildcard_constraints:
    case="|".join(DISCREPANCY_CASES) or "none",


rule discrepancy_discover:
    # One job makes the benchmark ensemble (its label apart: discover reads the ensemble's file
    # alone) and runs `uqdrive discover` on it: a job of its own per ensemble cost a Python start
    # and the package's imports (~0.5 s) for ~0.4 s of simulation, and the ensemble is remade to
    # the bit whenever the analysis settings change.
    input:
        src("studies.hidden_effects", "cli.discover", "inference.discrepancy"),
    output:
        measured=f"{DISC}/benchmark/measured/{{case}}.nc",
        label=f"{DISC}/benchmark/labels/{{case}}.json",
        verdict=directory(f"{DISC}/benchmark/discover/{{case}}"),
    params:
        **reads(*DISC_KEYS),
        figures=lambda w: w.case in FIGURE_CASES,
    threads: 1
    priority: LONG_JOB
    resources:
        mem_mb=3000,
        runtime=20,
    group: "discrepancy"
    log:
        f"{OUT}/logs/discrepancy_discover_{{case}}.log",
    benchmark:
        f"{OUT}/benchmarks/discrepancy_discover/discrepancy_discover_{{case}}.tsv",
    conda:
        "../envs/uqdrive.yaml"
    script:
        "../scripts/discrepancy_discover.py"


rule discrepancy_measured:
    input:
        src("cli.discover", "inference.discrepancy"),
        measured=lambda w: DISCREPANCY_MEASURED[w.name],
    output:
        directory(f"{DISC}/measured/{{name}}"),
    params:
        **reads(*DISC_KEYS),
    threads: 1
    resources:
        mem_mb=3000,
        runtime=20,
    group: "discrepancy"
    log:
        f"{OUT}/logs/discrepancy_measured_{{name}}.log",
    benchmark:
        f"{OUT}/benchmarks/discrepancy_measured/discrepancy_measured_{{name}}.tsv",
    conda:
        "../envs/uqdrive.yaml"
    script:
        "../scripts/discrepancy_discover.py"


rule discrepancy_summary:
    input:
        src("studies.discrepancy", "plots.discrepancy"),
        labels=expand(f"{DISC}/benchmark/labels/{{case}}.json", case=DISCREPANCY_CASES),
        verdicts=expand(f"{DISC}/benchmark/discover/{{case}}", case=DISCREPANCY_CASES),
        measured=expand(f"{DISC}/measured/{{name}}", name=DISCREPANCY_MEASURED),
    output:
        dataset=f"{DISC}/benchmark_summary.nc",
        table=report(f"{DISC}/benchmark_summary.csv", caption="../report/discrepancy_summary.rst", category="uqdrive discrepancy workflow",
                     labels={"figure": "benchmark summary (table)", "case": "hidden-effect benchmark"}),
        confusion=report(f"{FIG}/fig_discrepancy_confusion.png", caption="../report/discrepancy_confusion.rst", category="uqdrive discrepancy workflow",
                         labels={"figure": "confusion matrix", "case": "hidden-effect benchmark"}),
        detection=report(f"{FIG}/fig_discrepancy_detection.png", caption="../report/discrepancy_detection.rst", category="uqdrive discrepancy workflow",
                         labels={"figure": "detection against magnitude", "case": "hidden-effect benchmark"}),
        combined=report(f"{FIG}/fig_discrepancy_combined_confusion.png", caption="../report/discrepancy_combined.rst", category="uqdrive discrepancy workflow",
                        labels={"figure": "combined cases: hidden set x named set", "case": "hidden-effect benchmark"}),
        gaps=report(f"{FIG}/fig_discrepancy_gap_per_effect.png", caption="../report/discrepancy_combined.rst", category="uqdrive discrepancy workflow",
                    labels={"figure": "gap per added effect", "case": "hidden-effect benchmark"}),
        scorecard=f"{OUT}/scorecard/discrepancy.csv",
    threads: 1
    resources:
        mem_mb=1000,
        runtime=5,
    group: "summary"
    log:
        f"{OUT}/logs/discrepancy_summary.log",
    benchmark:
        f"{OUT}/benchmarks/discrepancy_summary/discrepancy_summary.tsv",
    conda:
        "../envs/uqdrive.yaml"
    script:
        "../scripts/discrepancy_summary.py"


rule discrepancy_thesis_figures:
    input:
        f"{DISC}/benchmark/discover/{THESIS_CASE}",
    output:
        bands=report(f"{FIG}/fig_discrepancy_thesis_bands.png", caption="../report/discrepancy_thesis.rst", category="uqdrive discrepancy workflow",
                     labels={"figure": "bands", "case": "thesis NLST data"}),
        localisation=report(f"{FIG}/fig_discrepancy_thesis_localisation.png", caption="../report/discrepancy_thesis.rst", category="uqdrive discrepancy workflow",
                            labels={"figure": "localisation", "case": "thesis NLST data"}),
    threads: 1
    resources:
        mem_mb=1000,
        runtime=2,
    group: "summary"
    log:
        f"{OUT}/logs/discrepancy_thesis_figures.log",
    benchmark:
        f"{OUT}/benchmarks/discrepancy_thesis_figures/discrepancy_thesis_figures.tsv",
    conda:
        "../envs/uqdrive.yaml"
    shell:
        "(cp {input}/bands.png {output.bands} && cp {input}/localisation.png {output.localisation}) 2> {log}"


CHANNEL_TABLE = config["discrepancy"]["channel_sets"]
#: The detection table's cells, one job each, in the table's order (run count, channel set, case).
CHANNEL_CELLS = [f"{DISC}/channel_sets/{s}/{n}/{c}.json" for n in CHANNEL_TABLE["runs"] for s in CHANNEL_TABLE["sets"] for c in CHANNEL_TABLE["cases"]]


rule discrepancy_channel_cell:
    input:
        src("studies.discrepancy", "studies.hidden_effects", "inference.discrepancy"),
    output:
        f"{DISC}/channel_sets/{{channel_set}}/{{runs}}/{{table_case}}.json",
    params:
        **reads(*DISC_KEYS),
    wildcard_constraints:
        channel_set="|".join(CHANNEL_TABLE["sets"]) or "none",
        runs=r"\d+",
        table_case="|".join(CHANNEL_TABLE["cases"]) or "none",
    threads: 1
    # config/config.yaml: one discover, at most 1483 MB and 12.5 min (actuator_lag_200ms along the speed profile, 20 runs, load 5-10; margins 1.5x, 3x)
    resources:
        mem_mb=2500,
        runtime=40,
    # one group of its own: the table's 45 cells travel as a few submissions (profiles' group-components)
    group: "detection"
    log:
        f"{OUT}/logs/discrepancy_channel_cell_{{channel_set}}_{{runs}}_{{table_case}}.log",
    benchmark:
        f"{OUT}/benchmarks/discrepancy_channel_cell/discrepancy_channel_cell_{{channel_set}}_{{runs}}_{{table_case}}.tsv",
    conda:
        "../envs/uqdrive.yaml"
    script:
        "../scripts/discrepancy_channel_cell.py"


rule discrepancy_channels:
    input:
        src("plots.discrepancy", "plots.figure", "io"),
        cells=CHANNEL_CELLS,
    output:
        table=report(f"{DISC}/channel_sets.csv", caption="../report/discrepancy_channels_table.rst", category="uqdrive discrepancy workflow",
                     labels={"figure": "detection by channel set (table)", "case": "IMU, speed profile, few runs"}),
        figure=report(f"{FIG}/fig_discrepancy_channel_sets.png", caption="../report/discrepancy_channels.rst", category="uqdrive discrepancy workflow",
                      labels={"figure": "detection by channel set and run count", "case": "IMU, speed profile, few runs"}),
    threads: 1
    resources:
        mem_mb=1000,
        runtime=2,
    group: "summary"
    log:
        f"{OUT}/logs/discrepancy_channels.log",
    benchmark:
        f"{OUT}/benchmarks/discrepancy_channels/discrepancy_channels.tsv",
    conda:
        "../envs/uqdrive.yaml"
    script:
        "../scripts/discrepancy_channels.py"


SCORECARD_PARTS.append("discrepancy")
FIGURES += [f"{FIG}/fig_discrepancy_channel_sets.png"]
FIGURES += [f"{FIG}/fig_discrepancy_confusion.png", f"{FIG}/fig_discrepancy_detection.png"]
if THESIS_CASE in DISCREPANCY_CASES:
    FIGURES += [f"{FIG}/fig_discrepancy_thesis_bands.png", f"{FIG}/fig_discrepancy_thesis_localisation.png"]

# The scorecard: every published number uqdrive reproduces, one CSV row each.


rule scorecard_foundation:
    input:
        src("studies.scorecard", "control.lqr", "vehicle.single_track", "vehicle.uncertainty", "vehicle.montecarlo"),
    output:
        f"{OUT}/scorecard/foundation.csv",
    params:
        **reads("vehicle", "tyre", "uncertainty.mu.mean", "uncertainty.m_load.mean", "uncertainty.l_f.mean", "control.Q_diag", "control.R",
                "wind.Tc", "wind.kle_quadrature", "wind.kle_truncation", "time.t_end"),
    log:
        f"{OUT}/logs/scorecard_foundation.log",
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
    log:
        f"{OUT}/logs/scorecard.log",
    conda:
        "../envs/uqdrive.yaml"
    script:
        "../scripts/scorecard_merge.py"


rule scorecard_provenance:
    input:
        src("io"),
        merged=f"{OUT}/scorecard/merged.csv",
    output:
        report(f"{OUT}/scorecard.csv", caption="../report/scorecard.rst", category="Scorecard"),
    params:
        provenance=PROVENANCE,
    log:
        f"{OUT}/logs/scorecard_provenance.log",
    conda:
        "../envs/uqdrive.yaml"
    script:
        "../scripts/scorecard_provenance.py"

# The scorecard: every published number uqdrive reproduces, one CSV row each.


rule scorecard_foundation:
    input:
        src("studies.scorecard", "control.lqr", "vehicle.single_track", "vehicle.uncertainty", "vehicle.montecarlo"),
    output:
        f"{OUT}/scorecard/foundation.csv",
    params:
        config=cfg("vehicle", "tyre", "uncertainty", "wind", "time", "control"),
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
        report(f"{OUT}/scorecard.csv", caption="../report/scorecard.rst", category="Scorecard"),
    log:
        f"{OUT}/logs/scorecard.log",
    conda:
        "../envs/uqdrive.yaml"
    script:
        "../scripts/scorecard_merge.py"

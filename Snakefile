# uqdrive: the whole reproduction as one DAG. Rules live in workflow/rules/*.smk.
include: "workflow/Snakefile"


rule all:
    default_target: True
    input:
        FIGURES,
        expand(f"{OUT}/data/stats_{{model}}_{{steer}}.nc", model=MODELS, steer=STEERS),
        f"{OUT}/scorecard.csv",

# uqdrive: the whole reproduction as one DAG. Rules live in workflow/rules/*.smk.
include: "workflow/Snakefile"


rule all:
    default_target: True
    input:
        FIGURES,
        expand(f"{OUT}/data/stats_{{model}}_{{steer}}.nc", model=MODELS, steer=STEERS),
        f"{OUT}/scorecard.csv",


rule reported:
    # What `make reproduce` and `make sweep` put in results/report.html: the outputs of `all`
    # that exist and every finished sweep (snakemake --report FILE reported).
    input:
        [f for f in [*FIGURES, *expand(f"{OUT}/data/stats_{{model}}_{{steer}}.nc", model=MODELS, steer=STEERS), f"{OUT}/scorecard.csv"] if Path(f).exists()],
        finished_sweeps(),

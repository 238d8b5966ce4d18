# Identification of the parameter distributions (thesis sec. 5.3, ch. 6.2) and identifiability.

ID_EXPERIMENTS = ["basic", "inverted", "initial_guess", "noise", "robust", "no_wind_moment", "normalised", "normalised_inverted"]
ID_STATS = {
    "lst_normal": f"{OUT}/data/stats_lst_normal.nc",
    "nlst_normal": f"{OUT}/data/stats_nlst_normal.nc",
    "lst_inverted": f"{OUT}/data/stats_lst_inverted.nc",
    "nlst_inverted": f"{OUT}/data/stats_nlst_inverted.nc",
    "noise_lst": f"{OUT}/data/noise_stats_lst.nc",
    "noise_nlst": f"{OUT}/data/noise_stats_nlst.nc",
    "lst_normal_no_wind_moment": f"{OUT}/data/stats_lst_normal_no_wind_moment.nc",
    "nlst_normal_no_wind_moment": f"{OUT}/data/stats_nlst_normal_no_wind_moment.nc",
}


rule stats_no_wind_moment:
    input:
        src("vehicle.single_track", "vehicle.uncertainty", "numerics.integrate", "vehicle.montecarlo", "vehicle.statistics", "studies.identification"),
    output:
        f"{OUT}/data/stats_{{model}}_normal_no_wind_moment.nc",
    wildcard_constraints:
        model="lst|nlst",
    params:
        config=cfg(*SIM_KEYS),
    log:
        f"{OUT}/logs/stats_{{model}}_normal_no_wind_moment.log",
    conda:
        "../envs/uqdrive.yaml"
    script:
        "../scripts/stats_no_wind_moment.py"


rule identification:
    input:
        src("inference.identify", "studies.identification", "vehicle.chaos", "numerics.galerkin", "numerics.pce", "numerics.polynomials", "numerics.integrate", "numerics.metrics", "rng"),
        **ID_STATS,
    output:
        f"{OUT}/data/identification_{{experiment}}.nc",
    wildcard_constraints:
        experiment="|".join(ID_EXPERIMENTS),
    params:
        config=cfg(*SIM_KEYS, "identification", "noise"),
        stats_keys=list(ID_STATS),
    log:
        f"{OUT}/logs/identification_{{experiment}}.log",
    conda:
        "../envs/uqdrive.yaml"
    script:
        "../scripts/identification.py"


rule identifiability:
    input:
        src("inference.identifiability", "vehicle.single_track"),
    output:
        f"{OUT}/data/identifiability.csv",
    params:
        config=cfg("vehicle", "tyre", "uncertainty", "steering"),
    log:
        f"{OUT}/logs/identifiability.log",
    conda:
        "../envs/uqdrive.yaml"
    script:
        "../scripts/identifiability.py"


ID_FIGS = [f"fig_6_{i}" for i in range(7, 16)] + ["fig_robust_start"]
B_FIGS = [f"fig_B{i}" for i in range(1, 14)]


rule fig_identification:
    input:
        src("plots.identification", "studies.tables", "studies.scorecard"),
        **{e: f"{OUT}/data/identification_{e}.nc" for e in ID_EXPERIMENTS},
        identifiability=f"{OUT}/data/identifiability.csv",
    output:
        figures=report(expand(f"{FIG}/{{name}}.png", name=ID_FIGS), caption="../report/identification.rst", category="Identification"),
        appendix=report(expand(f"{FIG}/{{name}}.png", name=B_FIGS), caption="../report/appendix_b.rst", category="Appendix B: estimated distributions"),
        table_6_2=report(f"{OUT}/tables/table_6_2.csv", caption="../report/table_6_2.rst", category="Identification"),
        table_6_3=report(f"{OUT}/tables/table_6_3.csv", caption="../report/table_6_3.rst", category="Identification"),
        identifiability=report(f"{OUT}/tables/identifiability.csv", caption="../report/identifiability.rst", category="Identification"),
        scorecard=f"{OUT}/scorecard/identification.csv",
    params:
        config=cfg(*SIM_KEYS, "identification", "noise"),
        experiments=ID_EXPERIMENTS,
    log:
        f"{OUT}/logs/fig_identification.log",
    conda:
        "../envs/uqdrive.yaml"
    script:
        "../scripts/fig_identification.py"

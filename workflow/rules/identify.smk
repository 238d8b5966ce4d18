# Identification of the parameter distributions (thesis sec. 5.3, ch. 6.2) and identifiability.
from uqdrive.studies.experiments import APPENDIX_B_PLAN, EXPERIMENTS

ID_EXPERIMENTS = list(EXPERIMENTS)
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
# The statistics each experiment fits (uqdrive.studies.identification.experiment_plan), both
# steerings' LST and NLST where its DST cost needs D_KL(NLST || LST); every experiment records
# the spun NLST runs of "nlst_normal".
_NORMAL, _INVERTED = ["lst_normal", "nlst_normal"], ["lst_inverted", "nlst_inverted", "nlst_normal"]
ID_INPUTS = {
    "basic": _NORMAL, "inverted": _INVERTED, "initial_guess": _NORMAL, "noise": _NORMAL + ["noise_lst", "noise_nlst"],
    "robust": _NORMAL, "no_wind_moment": ["lst_normal_no_wind_moment", "nlst_normal_no_wind_moment", "nlst_normal"],
    "normalised": _NORMAL, "normalised_inverted": _INVERTED,
}
#: The ensembles of the Table 6.2 variant without the wind's yaw moment: M_c = 0 (set on the
#: settings by uqdrive.studies.experiments.experiment_settings, so vehicle.M_c is not read), the
#: rest as any ensemble; their statistics come from the rule statistics.
NO_WIND_MOMENT_KEYS = ("seed", "vehicle.m_base", "vehicle.J0", "vehicle.wheelbase", "vehicle.c_Sf", "vehicle.c_Sr", "vehicle.speed_kmh",
                       "vehicle.g", "tyre", "uncertainty", "wind", "steering", "time", "montecarlo.samples", "montecarlo.spin_threshold")
#: What every identification reads: the model, the estimator's settings, the seed of its guesses.
ID_KEYS = ("seed",) + MODEL_KEYS + ("identification.order", "identification.quadrature_points", "identification.max_iter",
                                    "identification.optimiser", "identification.runs")
_SI, _UNIT_FREE = ("identification.basic_deviation", "identification.state_scale"), ("identification.basic_deviation", "identification.normalised_state_scale")
#: What only some experiments read (experiment_plan; the residual scale of their tasks).
ID_EXPERIMENT_KEYS = {
    "basic": _SI, "inverted": _SI, "no_wind_moment": _SI, "normalised": _UNIT_FREE, "normalised_inverted": _UNIT_FREE,
    "initial_guess": ("identification.initial_guess_deviations", "identification.fixed_deviation", "identification.state_scale"),
    "noise": ("noise.levels", "identification.fixed_deviation", "identification.state_scale"),
    "robust": ("identification.robust_deviations", "identification.robust_starts", "identification.fixed_deviation", "identification.state_scale"),
}


rule ensemble_no_wind_moment:
    input:
        src("vehicle.single_track", "vehicle.uncertainty", "numerics.integrate", "vehicle.montecarlo", "io", "studies.identification", "studies.experiments"),
    output:
        f"{OUT}/data/ensemble_{{model}}_{{steer}}_no_wind_moment.nc",
    wildcard_constraints:
        model="lst|nlst",
        steer="normal",
    params:
        **reads(*NO_WIND_MOMENT_KEYS),
        experiment="no_wind_moment",
    threads: 1
    resources:
        mem_mb=2000,
        runtime=10,
    group: "data"
    log:
        f"{OUT}/logs/ensemble_{{model}}_{{steer}}_no_wind_moment.log",
    benchmark:
        f"{OUT}/benchmarks/ensemble_no_wind_moment/ensemble_{{model}}_{{steer}}_no_wind_moment.tsv",
    cache: CACHE
    conda:
        "../envs/uqdrive.yaml"
    script:
        "../scripts/ensemble.py"


rule identification:
    input:
        src("inference.identify", "studies.identification", "vehicle.chaos", "numerics.galerkin", "numerics.pce", "numerics.polynomials", "numerics.integrate", "numerics.metrics", "rng"),
        unpack(lambda w: {key: ID_STATS[key] for key in ID_INPUTS[w.experiment]}),
    output:
        f"{OUT}/data/identification_{{experiment}}.nc",
    wildcard_constraints:
        experiment="|".join(ID_EXPERIMENTS),
    params:
        **reads(*ID_KEYS, per_job=("experiment", ID_EXPERIMENT_KEYS)),
        stats_keys=lambda w: ID_INPUTS[w.experiment],
    threads: 1
    priority: LONG_JOB  # the eight feed fig_identification: started last, they end the DAG on one core
    resources:
        mem_mb=2000,
        runtime=20,
    group: "identification"
    log:
        f"{OUT}/logs/identification_{{experiment}}.log",
    benchmark:
        f"{OUT}/benchmarks/identification/identification_{{experiment}}.tsv",
    cache: CACHE
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
        **reads("vehicle", "tyre.C", "uncertainty.mu.mean", "uncertainty.m_load.mean", "uncertainty.l_f.mean", "uncertainty.F_w_mean",
                "steering.delta_max_deg"),
    threads: 1
    resources:
        mem_mb=1000,
        runtime=10,
    group: "identification"
    log:
        f"{OUT}/logs/identifiability.log",
    benchmark:
        f"{OUT}/benchmarks/identifiability/identifiability.tsv",
    cache: CACHE
    conda:
        "../envs/uqdrive.yaml"
    script:
        "../scripts/identifiability.py"


ID_FIGS = [f"fig_6_{i}" for i in range(7, 16)] + ["fig_robust_start"]
B_FIGS = [f"fig_B{i}" for i in range(1, 14)]
#: The report's labels of the identification figures: the experiment, the figure, what it shows.
ID_LABELS = {
    "fig_6_7": ("basic", "Fig. 6.7", "W2 per run, LST-LST"), "fig_6_8": ("basic", "Fig. 6.8", "W2 per run, NLST-LST"),
    "fig_6_9": ("inverted steering", "Fig. 6.9", "distributions, NLST-LST [STD]"),
    "fig_6_10": ("basic", "Fig. 6.10", "tyre curves with the identified mu"),
    "fig_6_11": ("initial guess", "Fig. 6.11", "W2 against the initial deviation, LST-LST"),
    "fig_6_12": ("initial guess", "Fig. 6.12", "W2 against the initial deviation, NLST-LST"),
    "fig_6_13": ("noise", "Fig. 6.13", "W2 against the noise level, LST-LST"), "fig_6_14": ("noise", "Fig. 6.14", "W2 against the noise level, NLST-LST"),
    "fig_6_15": ("noise", "Fig. 6.15", "distributions per noise level, LST-LST [STD]"),
    "fig_robust_start": ("robust start", "past the thesis", "W2 against the initial deviation, single vs multi-start"),
}


rule fig_identification:
    input:
        src("plots.identification", "studies.tables", "studies.scorecard"),
        **{e: f"{OUT}/data/identification_{e}.nc" for e in ID_EXPERIMENTS},
        identifiability=f"{OUT}/data/identifiability.csv",
    output:
        figures=[report(f"{FIG}/{name}.png", caption="../report/identification.rst", category="Thesis 6.2 Identification", subcategory="figures",
                        labels=dict(zip(("experiment", "figure", "shows"), ID_LABELS[name]))) for name in ID_FIGS],
        appendix=[report(f"{FIG}/{name}.png", caption="../report/appendix_b.rst", category="Thesis appendix B Estimated distributions",
                         labels={"experiment": exp.replace("_", " "), "data": est.split("-")[0], "cost function": est.split("-")[1], "figure": f"Fig. B.{k}"})
                  for k, (name, (exp, est)) in enumerate(zip(B_FIGS, APPENDIX_B_PLAN), 1)],
        table_6_2=report(f"{OUT}/tables/table_6_2.csv", caption="../report/table_6_2.rst", category="Thesis 6.2 Identification", subcategory="tables",
                         labels={"experiment": "basic", "table": "Table 6.2", "shows": "identified distributions beside the thesis"}),
        table_6_3=report(f"{OUT}/tables/table_6_3.csv", caption="../report/table_6_3.rst", category="Thesis 6.2 Identification", subcategory="tables",
                         labels={"experiment": "inverted steering", "table": "Table 6.3", "shows": "identified distributions beside the thesis"}),
        identifiability=report(f"{OUT}/tables/identifiability.csv", caption="../report/identifiability.rst", category="Thesis 6.2 Identification", subcategory="tables",
                               labels={"experiment": "identifiability", "table": "rank table", "shows": "observability rank (sec. 5.3.1)"}),
        scorecard=f"{OUT}/scorecard/identification.csv",
    params:
        **reads("vehicle", "tyre", "uncertainty.mu.mean", "uncertainty.m_load.mean", "uncertainty.l_f.mean", "noise.levels"),
        experiments=ID_EXPERIMENTS,
    threads: 1
    resources:
        mem_mb=1500,
        runtime=10,
    group: "identification"
    log:
        f"{OUT}/logs/fig_identification.log",
    benchmark:
        f"{OUT}/benchmarks/fig_identification/fig_identification.tsv",
    conda:
        "../envs/uqdrive.yaml"
    script:
        "../scripts/fig_identification.py"


rule identify_coverage:
    # Calibration of `uqdrive identify`'s 95 % intervals and misfit test on seeded replicates.
    input:
        src("inference.identify", "inference.sampling", "studies.identification", "vehicle.chaos", "vehicle.montecarlo", "numerics.galerkin",
            "numerics.pce", "numerics.polynomials", "numerics.integrate", "rng"),
    output:
        table=report(f"{OUT}/tables/identify_coverage.csv", caption="../report/identify_coverage.rst", category="Thesis 6.2 Identification",
                     subcategory="tables", labels={"experiment": "error-bar calibration", "table": "coverage", "shows": "95 % intervals cover the truth"}),
    params:
        **reads("seed", *MODEL_KEYS, "montecarlo.spin_threshold", "identification.order", "identification.quadrature_points", "identification.coverage"),
    threads: 1
    resources:
        mem_mb=1500,
        runtime=20,
    group: "identification"
    log:
        f"{OUT}/logs/identify_coverage.log",
    benchmark:
        f"{OUT}/benchmarks/identify_coverage/identify_coverage.tsv",
    conda:
        "../envs/uqdrive.yaml"
    script:
        "../scripts/identify_coverage.py"

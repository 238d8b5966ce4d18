# emcee cross-check of the identified distributions (LST-LST, NLST-LST, noisy LST).

BAYES_CASES = ["lst", "nlst", "lst_noise"]
BAYES_CASE_NAMES = {"lst": "LST-LST", "nlst": "NLST-LST", "lst_noise": f"LST-LST, noise A = {config['bayes']['noise_level']}"}
#: What both posterior rules read: the data's spin policy, the PCE model, the optimiser's settings
#: (estimates with SI and unit-free residuals), the sampler's settings (uqdrive.studies.bayes).
BAYES_KEYS = ("seed",) + MODEL_KEYS + ("montecarlo.spin_policy", "identification.order", "identification.quadrature_points",
                                      "identification.max_iter", "identification.state_scale", "identification.normalised_state_scale",
                                      "identification.optimiser", "bayes.likelihood_dt", "bayes.model_dt", "bayes.model_error",
                                      "bayes.walkers", "bayes.check_every", "bayes.tau_factor", "bayes.burn_in", "bayes.moves",
                                      "bayes.model_gusts", "bayes.prior")
BAYES_SRC = ("inference.bayes", "studies.bayes", "inference.identify", "vehicle.chaos", "numerics.galerkin", "numerics.pce", "numerics.polynomials", "numerics.integrate", "vehicle.noise", "rng")


rule posterior:
    input:
        src(*BAYES_SRC),
        ensemble=lambda w: f"{OUT}/data/ensemble_{w.case.split('_')[0]}_normal.nc",
    output:
        f"{OUT}/data/posterior_{{case}}.nc",
    wildcard_constraints:
        case="|".join(BAYES_CASES),
    params:
        **reads(*BAYES_KEYS, "bayes.ensembles", "bayes.dispersion", "bayes.max_steps", per_job=("case", {"lst_noise": ("bayes.noise_level",)})),
    threads: 1
    priority: LONG_JOB
    resources:
        mem_mb=2000,
        runtime=40,
    group: "bayes"
    log:
        f"{OUT}/logs/posterior_{{case}}.log",
    benchmark:
        f"{OUT}/benchmarks/posterior/posterior_{{case}}.tsv",
    cache: CACHE
    conda:
        "../envs/uqdrive.yaml"
    script:
        "../scripts/posterior.py"


rule posterior_coverage:
    input:
        src(*BAYES_SRC, "vehicle.montecarlo"),
    output:
        f"{OUT}/data/posterior_coverage.nc",
    params:
        **reads(*BAYES_KEYS, "montecarlo.samples", "montecarlo.spin_threshold", "bayes.calibration_sets", "bayes.calibration_steps"),
    threads: 1
    priority: LONG_JOB
    resources:
        mem_mb=2000,
        runtime=40,
    group: "bayes"
    log:
        f"{OUT}/logs/posterior_coverage.log",
    benchmark:
        f"{OUT}/benchmarks/posterior_coverage/posterior_coverage.tsv",
    cache: CACHE
    conda:
        "../envs/uqdrive.yaml"
    script:
        "../scripts/posterior_coverage.py"


rule fig_bayes:
    input:
        src("plots.bayes", "studies.bayes", "studies.scorecard"),
        posteriors=expand(f"{OUT}/data/posterior_{{case}}.nc", case=BAYES_CASES),
        coverage=f"{OUT}/data/posterior_coverage.nc",
    output:
        # One row per case, corner/trace as the toggle the report makes of a two-valued label.
        corners=[report(f"{FIG}/posterior_corner_{case}.png", caption="../report/posterior_corner.rst", category="uqdrive emcee cross-check", subcategory="posteriors",
                        labels={"case": BAYES_CASE_NAMES[case], "plot": "corner"}) for case in BAYES_CASES],
        traces=[report(f"{FIG}/posterior_trace_{case}.png", caption="../report/posterior_trace.rst", category="uqdrive emcee cross-check", subcategory="posteriors",
                       labels={"case": BAYES_CASE_NAMES[case], "plot": "trace"}) for case in BAYES_CASES],
        table=report(f"{OUT}/tables/posterior_summary.csv", caption="../report/posterior_summary.rst", category="uqdrive emcee cross-check", subcategory="summary",
                     labels={"table": "posterior summary"}),
        scorecard=f"{OUT}/scorecard/bayes.csv",
    params:
        cases=BAYES_CASES,
    threads: 1
    resources:
        mem_mb=1000,
        runtime=10,
    group: "bayes"
    log:
        f"{OUT}/logs/fig_bayes.log",
    benchmark:
        f"{OUT}/benchmarks/fig_bayes/fig_bayes.tsv",
    conda:
        "../envs/uqdrive.yaml"
    script:
        "../scripts/fig_bayes.py"

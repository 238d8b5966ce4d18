# Synthetic measured data (thesis sec. 5.1): KLE of the wind, Monte Carlo ensembles, statistics.


rule kle:
    input:
        src("vehicle.uncertainty", "studies.kle", "vehicle.montecarlo"),
    output:
        f"{OUT}/data/kle.nc",
    params:
        **reads("seed", "time", "wind.Tc", "wind.kle_quadrature", "wind.kle_truncation", "figures.kle_realisations"),
    threads: 1
    resources:
        mem_mb=1000,
        runtime=5,
    group: "data"
    log:
        f"{OUT}/logs/kle.log",
    benchmark:
        f"{OUT}/benchmarks/kle/kle.tsv",
    cache: CACHE
    conda:
        "../envs/uqdrive.yaml"
    script:
        "../scripts/kle.py"


rule ensemble:
    input:
        src("vehicle.single_track", "vehicle.uncertainty", "numerics.integrate", "vehicle.montecarlo", "io"),
    output:
        f"{OUT}/data/ensemble_{{model}}_{{steer}}.nc",
    params:
        **reads(*ENSEMBLE_KEYS),
    wildcard_constraints:
        model="lst|nlst",
        steer="normal|inverted",
    threads: 1
    resources:
        mem_mb=2000,
        runtime=10,
    group: "data"
    log:
        f"{OUT}/logs/ensemble_{{model}}_{{steer}}.log",
    benchmark:
        f"{OUT}/benchmarks/ensemble/ensemble_{{model}}_{{steer}}.tsv",
    cache: CACHE
    conda:
        "../envs/uqdrive.yaml"
    script:
        "../scripts/ensemble.py"


rule statistics:
    input:
        src("vehicle.statistics", "io"),
        ensemble=f"{OUT}/data/ensemble_{{model}}_{{steer}}.nc",
    output:
        f"{OUT}/data/stats_{{model}}_{{steer}}.nc",
    wildcard_constraints:
        model="lst|nlst",
    params:
        **reads(spin_policy="montecarlo.spin_policy"),
    threads: 1
    resources:
        mem_mb=2000,
        runtime=5,
    group: "data"
    log:
        f"{OUT}/logs/stats_{{model}}_{{steer}}.log",
    benchmark:
        f"{OUT}/benchmarks/statistics/stats_{{model}}_{{steer}}.tsv",
    cache: CACHE
    conda:
        "../envs/uqdrive.yaml"
    script:
        "../scripts/statistics.py"


rule noise_statistics:
    input:
        src("vehicle.statistics", "vehicle.noise", "io"),
        ensemble=f"{OUT}/data/ensemble_{{model}}_normal.nc",
    output:
        f"{OUT}/data/noise_stats_{{model}}.nc",
    params:
        **reads(levels="noise.levels", seed="seed", spin_policy="montecarlo.spin_policy"),
    threads: 1
    resources:
        mem_mb=2000,
        runtime=5,
    group: "data"
    log:
        f"{OUT}/logs/noise_stats_{{model}}.log",
    benchmark:
        f"{OUT}/benchmarks/noise_statistics/noise_stats_{{model}}.tsv",
    cache: CACHE
    conda:
        "../envs/uqdrive.yaml"
    script:
        "../scripts/noise_statistics.py"


rule kl_divergence:
    input:
        src("vehicle.statistics", "numerics.metrics"),
        lst=f"{OUT}/data/stats_lst_normal.nc",
        nlst=f"{OUT}/data/stats_nlst_normal.nc",
    output:
        f"{OUT}/data/kl_nlst_lst.nc",
    threads: 1
    resources:
        mem_mb=1000,
        runtime=5,
    group: "data"
    log:
        f"{OUT}/logs/kl_nlst_lst.log",
    benchmark:
        f"{OUT}/benchmarks/kl_divergence/kl_nlst_lst.tsv",
    conda:
        "../envs/uqdrive.yaml"
    script:
        "../scripts/kl_divergence.py"

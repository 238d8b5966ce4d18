# Polynomial chaos of the LST (thesis ch. 4, sec. 5.2): moments, Sobol indices, convergence.

#: What the PCE model of the LST reads (uqdrive.vehicle.chaos.LSTChaosModel), with the seed of
#: the datasets' provenance.
PCE_KEYS = ("seed",) + MODEL_KEYS


rule pce_moments:
    input:
        src("numerics.polynomials", "numerics.pce", "numerics.galerkin", "numerics.integrate", "vehicle.chaos", "studies.pce", "vehicle.single_track", "vehicle.uncertainty"),
    output:
        f"{OUT}/data/pce_lst.nc",
    params:
        **reads(*PCE_KEYS, "pce.order", "pce.quadrature_points"),
    threads: 1
    resources:
        mem_mb=1000,
        runtime=5,
    group: "pce"
    log:
        f"{OUT}/logs/pce_lst.log",
    benchmark:
        f"{OUT}/benchmarks/pce_moments/pce_lst.tsv",
    cache: CACHE
    conda:
        "../envs/uqdrive.yaml"
    script:
        "../scripts/pce_moments.py"


rule mc_reference:
    input:
        src("vehicle.single_track", "vehicle.uncertainty", "numerics.integrate", "vehicle.montecarlo"),
    output:
        f"{OUT}/data/mc_reference_lst.nc",
    params:
        **reads(*PCE_KEYS, "montecarlo.spin_threshold", "pce.convergence.reference_samples", "pce.convergence.chunk"),
    threads: 1
    resources:
        mem_mb=2000,
        runtime=10,
    group: "pce"
    log:
        f"{OUT}/logs/mc_reference_lst.log",
    benchmark:
        f"{OUT}/benchmarks/mc_reference/mc_reference_lst.tsv",
    cache: CACHE
    conda:
        "../envs/uqdrive.yaml"
    script:
        "../scripts/mc_reference.py"


rule pce_convergence:
    input:
        src("numerics.polynomials", "numerics.pce", "numerics.galerkin", "numerics.integrate", "vehicle.chaos", "studies.pce"),
        reference=f"{OUT}/data/mc_reference_lst.nc",
    output:
        f"{OUT}/data/pce_convergence.nc",
    params:
        **reads(*PCE_KEYS, "pce.convergence.orders", "pce.convergence.quadrature_points"),
    threads: 1
    resources:
        mem_mb=1000,
        runtime=10,
    group: "pce"
    log:
        f"{OUT}/logs/pce_convergence.log",
    benchmark:
        f"{OUT}/benchmarks/pce_convergence/pce_convergence.tsv",
    cache: CACHE
    conda:
        "../envs/uqdrive.yaml"
    script:
        "../scripts/pce_convergence.py"


rule fig_pce:
    input:
        src("plots.pce"),
        pce=f"{OUT}/data/pce_lst.nc",
        mc=f"{OUT}/data/stats_lst_normal.nc",
        convergence=f"{OUT}/data/pce_convergence.nc",
    output:
        comparison=report(f"{FIG}/fig_5_3.png", caption="../report/fig_5_3.rst", category="Thesis 5 Wind and polynomial chaos", subcategory="Polynomial chaos",
                          labels={"figure": "Fig. 5.3", "content": "PCE against Monte Carlo"}),
        sobol=report(f"{FIG}/fig_5_4.png", caption="../report/fig_5_4.rst", category="Thesis 5 Wind and polynomial chaos", subcategory="Polynomial chaos",
                     labels={"figure": "Fig. 5.4", "content": "first-order Sobol indices"}),
        convergence=report(f"{FIG}/fig_pce_convergence.png", caption="../report/fig_pce_convergence.rst", category="Thesis 5 Wind and polynomial chaos", subcategory="Polynomial chaos",
                           labels={"figure": "PCE convergence", "content": "past the thesis: error against N_PCE"}),
    params:
        **reads(band_sigmas="figures.band_sigmas"),
    threads: 1
    resources:
        mem_mb=1000,
        runtime=5,
    group: "pce"
    log:
        f"{OUT}/logs/fig_pce.log",
    benchmark:
        f"{OUT}/benchmarks/fig_pce/fig_pce.tsv",
    conda:
        "../envs/uqdrive.yaml"
    script:
        "../scripts/fig_pce.py"

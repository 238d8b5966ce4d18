# Polynomial chaos of the LST (thesis ch. 4, sec. 5.2): moments, Sobol indices, convergence.

PCE_KEYS = SIM_KEYS + ("pce",)


rule pce_moments:
    input:
        src("numerics.polynomials", "numerics.pce", "numerics.galerkin", "numerics.integrate", "vehicle.chaos", "studies.pce", "vehicle.single_track", "vehicle.uncertainty"),
    output:
        f"{OUT}/data/pce_lst.nc",
    params:
        config=cfg(*PCE_KEYS),
    log:
        f"{OUT}/logs/pce_lst.log",
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
        config=cfg(*PCE_KEYS),
    log:
        f"{OUT}/logs/mc_reference_lst.log",
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
        config=cfg(*PCE_KEYS),
    log:
        f"{OUT}/logs/pce_convergence.log",
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
        comparison=report(f"{FIG}/fig_5_3.png", caption="../report/fig_5_3.rst", category="Polynomial chaos"),
        sobol=report(f"{FIG}/fig_5_4.png", caption="../report/fig_5_4.rst", category="Polynomial chaos"),
        convergence=report(f"{FIG}/fig_pce_convergence.png", caption="../report/fig_pce_convergence.rst", category="Polynomial chaos"),
    params:
        band_sigmas=config["figures"]["band_sigmas"],
    log:
        f"{OUT}/logs/fig_pce.log",
    conda:
        "../envs/uqdrive.yaml"
    script:
        "../scripts/fig_pce.py"

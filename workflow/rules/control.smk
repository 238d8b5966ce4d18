# LQR and stochastic LQR on the PCE model: the lane-keeping test case (thesis sec. 5.4, 6.3).

#: What every controller design reads: the vehicle's distributions and the wind's KLE on [0, t_end],
#: the time step of the lane-keeping case, its initial conditions, the seed of the provenance.
CONTROL_KEYS = ("seed", "vehicle", "tyre", "uncertainty", "wind", "time.t_end", "time.dt", "control.y0", "control.psi0_deg")
CONTROL_SRC = ("control.lqr", "studies.control", "control.slqr", "numerics.galerkin", "numerics.pce", "numerics.polynomials", "numerics.integrate", "vehicle.single_track", "vehicle.uncertainty", "vehicle.montecarlo", "rng")


rule control_gains:
    input:
        src(*CONTROL_SRC),
        identified=f"{OUT}/data/identification_basic.nc",
    output:
        f"{OUT}/data/control_gains.nc",
    params:
        **reads(*CONTROL_KEYS, "control.Q_diag", "control.R", "control.order", "control.gamma", "control.horizon", "control.simulation_time"),
    threads: 1
    resources:
        mem_mb=1000,
        runtime=10,
    group: "control"
    log:
        f"{OUT}/logs/control_gains.log",
    benchmark:
        f"{OUT}/benchmarks/control_gains/control_gains.tsv",
    cache: CACHE
    conda:
        "../envs/uqdrive.yaml"
    script:
        "../scripts/control_gains.py"


rule control_monte_carlo:
    input:
        src(*CONTROL_SRC),
        gains=f"{OUT}/data/control_gains.nc",
    output:
        f"{OUT}/data/control_mc_{{model}}.nc",
    wildcard_constraints:
        model="lst|nlst",
    params:
        **reads(*CONTROL_KEYS, "time.step", "control.samples", "control.simulation_time"),
    threads: 1
    resources:
        mem_mb=2000,
        runtime=10,
    group: "control"
    log:
        f"{OUT}/logs/control_mc_{{model}}.log",
    benchmark:
        f"{OUT}/benchmarks/control_monte_carlo/control_mc_{{model}}.tsv",
    cache: CACHE
    conda:
        "../envs/uqdrive.yaml"
    script:
        "../scripts/control_monte_carlo.py"


rule control_gamma_sweep:
    input:
        src(*CONTROL_SRC),
    output:
        f"{OUT}/data/control_gamma_sweep.nc",
    params:
        **reads(*CONTROL_KEYS, "control.Q_diag", "control.R", "control.order", "control.gamma_sweep", "control.horizon"),
    threads: 1
    resources:
        mem_mb=1000,
        runtime=10,
    group: "control"
    log:
        f"{OUT}/logs/control_gamma_sweep.log",
    benchmark:
        f"{OUT}/benchmarks/control_gamma_sweep/control_gamma_sweep.tsv",
    cache: CACHE
    conda:
        "../envs/uqdrive.yaml"
    script:
        "../scripts/control_gamma_sweep.py"


rule fig_control:
    input:
        src("plots.control", "studies.control", "studies.scorecard"),
        gains=f"{OUT}/data/control_gains.nc",
        lst=f"{OUT}/data/control_mc_lst.nc",
        nlst=f"{OUT}/data/control_mc_nlst.nc",
        sweep=f"{OUT}/data/control_gamma_sweep.nc",
    output:
        fig_6_16=report(f"{FIG}/fig_6_16.png", caption="../report/fig_6_16.rst", category="Thesis 6.3 Control", labels={"figure": "Fig. 6.16", "content": "LST with the LQR"}),
        fig_6_17=report(f"{FIG}/fig_6_17.png", caption="../report/fig_6_17.rst", category="Thesis 6.3 Control", labels={"figure": "Fig. 6.17", "content": "LST, LQR and SLQR"}),
        fig_6_18=report(f"{FIG}/fig_6_18.png", caption="../report/fig_6_18.rst", category="Thesis 6.3 Control", labels={"figure": "Fig. 6.18", "content": "NLST, LQR and SLQR"}),
        sweep=report(f"{FIG}/fig_gamma_sweep.png", caption="../report/fig_gamma_sweep.rst", category="Thesis 6.3 Control",
                     labels={"figure": "gamma sweep", "content": "past the thesis: SLQR cost against gamma"}),
        table=report(f"{OUT}/tables/control_gains.csv", caption="../report/control_gains.rst", category="Thesis 6.3 Control",
                     labels={"figure": "Eqs. (6.1), (6.2)", "content": "gains and closed-loop statistics (table)"}),
        scorecard=f"{OUT}/scorecard/control.csv",
    params:
        **reads(band_sigmas="figures.band_sigmas"),
    threads: 1
    resources:
        mem_mb=1000,
        runtime=5,
    group: "control"
    log:
        f"{OUT}/logs/fig_control.log",
    benchmark:
        f"{OUT}/benchmarks/fig_control/fig_control.tsv",
    conda:
        "../envs/uqdrive.yaml"
    script:
        "../scripts/fig_control.py"

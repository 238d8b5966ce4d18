# The GP wheel-slip paper: GP of the friction curve, PID tuning, calibration, closed loop.

WS_SIZES = config["wheelslip"]["gp"]["training_sizes"]
#: The quarter car and the design constants (uqdrive.wheelslip.quarter_car.QuarterCar.from_settings).
WS_CAR_KEYS = ("wheelslip.r", "wheelslip.F_z", "wheelslip.mass", "wheelslip.J", "wheelslip.T_a", "wheelslip.k", "wheelslip.mu_H",
               "wheelslip.lambda_star", "wheelslip.zeta_d", "wheelslip.omega_0d")
#: How the GP is fitted to noisy friction measurements (uqdrive.wheelslip.calibration.fit_friction_gp).
WS_GP_KEYS = ("wheelslip.gp.training_slip", "wheelslip.gp.noise_std", "wheelslip.gp.restarts")


WS_SRC = ("wheelslip.gp", "wheelslip.quarter_car", "wheelslip.calibration", "studies.wheelslip", "rng")


rule wheelslip_gp:
    input:
        src(*WS_SRC),
    output:
        f"{OUT}/data/wheelslip_gp_{{n}}.nc",
    wildcard_constraints:
        n=r"\d+",
    params:
        **reads("seed", *WS_CAR_KEYS, *WS_GP_KEYS, "wheelslip.speed"),
    threads: 1
    resources:
        mem_mb=1000,
        runtime=5,
    group: "wheelslip"
    log:
        f"{OUT}/logs/wheelslip_gp_{{n}}.log",
    benchmark:
        f"{OUT}/benchmarks/wheelslip_gp/wheelslip_gp_{{n}}.tsv",
    cache: CACHE
    conda:
        "../envs/uqdrive.yaml"
    script:
        "../scripts/wheelslip_gp.py"


rule wheelslip_calibration:
    input:
        src(*WS_SRC),
        gp=f"{OUT}/data/wheelslip_gp_{{n}}.nc",
    output:
        f"{OUT}/data/wheelslip_calibration_{{n}}.nc",
    wildcard_constraints:
        n=r"\d+",
    params:
        **reads("seed", *WS_CAR_KEYS, *WS_GP_KEYS, "wheelslip.calibration.sets", "wheelslip.calibration.prior_sets",
                "wheelslip.calibration.walkers", "wheelslip.calibration.steps", "wheelslip.calibration.burn"),
        mcmc_sets=lambda wildcards, input: ws_mcmc_sets(wildcards.n),
        mcmc_trigger=lambda w: {"wheelslip.calibration.mcmc_sets": ws_mcmc_sets(w.n)},  # this size's entry
    threads: 1
    priority: LONG_JOB
    resources:
        mem_mb=2000,
        runtime=30,
    group: "wheelslip"
    log:
        f"{OUT}/logs/wheelslip_calibration_{{n}}.log",
    benchmark:
        f"{OUT}/benchmarks/wheelslip_calibration/wheelslip_calibration_{{n}}.tsv",
    cache: CACHE
    conda:
        "../envs/uqdrive.yaml"
    script:
        "../scripts/wheelslip_calibration.py"


rule wheelslip_closed_loop:
    input:
        src(*WS_SRC),
        gp=f"{OUT}/data/wheelslip_gp_{WS_SIZES[0]}.nc",
    output:
        f"{OUT}/data/wheelslip_closed_loop.nc",
    params:
        **reads("seed", *WS_CAR_KEYS, "wheelslip.speed", "wheelslip.closed_loop"),
    threads: 1
    resources:
        mem_mb=1000,
        runtime=5,
    group: "wheelslip"
    log:
        f"{OUT}/logs/wheelslip_closed_loop.log",
    benchmark:
        f"{OUT}/benchmarks/wheelslip_closed_loop/wheelslip_closed_loop.tsv",
    cache: CACHE
    conda:
        "../envs/uqdrive.yaml"
    script:
        "../scripts/wheelslip_closed_loop.py"


rule fig_wheelslip:
    input:
        src("plots.wheelslip", "wheelslip.quarter_car"),
        gp=expand(f"{OUT}/data/wheelslip_gp_{{n}}.nc", n=WS_SIZES),
        calibration=expand(f"{OUT}/data/wheelslip_calibration_{{n}}.nc", n=WS_SIZES),
        closed_loop=f"{OUT}/data/wheelslip_closed_loop.nc",
    output:
        curves=report(f"{FIG}/paper_fig_4.png", caption="../report/paper_fig_4.rst", category="Paper GP friction model",
                      labels={"figure": "Fig. 4", "content": "slip/friction curves"}),
        function=report(f"{FIG}/paper_fig_5.png", caption="../report/paper_fig_5.rst", category="Paper GP friction model",
                        labels={"figure": "Fig. 5", "content": "GP of the friction coefficient"}),
        slope=report(f"{FIG}/paper_fig_6.png", caption="../report/paper_fig_6.rst", category="Paper GP friction model",
                     labels={"figure": "Fig. 6", "content": "GP of the slope"}),
        poles=[report(f"{FIG}/paper_fig_poles_{n}.png", caption="../report/paper_fig_poles.rst", category="Paper wheel-slip PID",
                      labels={"figure": "Figs. 7, 8", "content": f"closed-loop poles, {n} training points"}) for n in WS_SIZES],
        schedule=report(f"{FIG}/paper_pid_schedule.png", caption="../report/paper_pid_schedule.rst", category="Paper wheel-slip PID",
                        labels={"figure": "Eqs. (28)-(29)", "content": "PID schedule"}),
        calibration=report(f"{FIG}/paper_calibration.png", caption="../report/paper_calibration.rst", category="Paper GP friction model",
                           labels={"figure": "calibration", "content": "past the paper: coverage of the slope interval"}),
        closed_loop=report(f"{FIG}/paper_closed_loop.png", caption="../report/paper_closed_loop.rst", category="Paper wheel-slip PID",
                           labels={"figure": "closed loop", "content": "past the paper: quarter car under the GP-tuned PID"}),
    params:
        **reads(*WS_CAR_KEYS, "wheelslip.curves_mu_H", "wheelslip.paper_slope.mean", "wheelslip.speed_range"),
    threads: 1
    resources:
        mem_mb=1000,
        runtime=5,
    group: "wheelslip"
    log:
        f"{OUT}/logs/fig_wheelslip.log",
    benchmark:
        f"{OUT}/benchmarks/fig_wheelslip/fig_wheelslip.tsv",
    conda:
        "../envs/uqdrive.yaml"
    script:
        "../scripts/fig_wheelslip.py"


rule scorecard_wheelslip:
    input:
        src("studies.scorecard", "wheelslip.quarter_car"),
        calibration=expand(f"{OUT}/data/wheelslip_calibration_{{n}}.nc", n=WS_SIZES),
    output:
        f"{OUT}/scorecard/wheelslip.csv",
    params:
        **reads(*WS_CAR_KEYS, "wheelslip.paper_slope", "wheelslip.speed", "wheelslip.gp.training_slip"),
    threads: 1
    resources:
        mem_mb=1000,
        runtime=5,
    group: "wheelslip"
    log:
        f"{OUT}/logs/scorecard_wheelslip.log",
    benchmark:
        f"{OUT}/benchmarks/scorecard_wheelslip/scorecard_wheelslip.tsv",
    conda:
        "../envs/uqdrive.yaml"
    script:
        "../scripts/scorecard_wheelslip.py"

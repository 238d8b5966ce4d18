# Figures of the thesis' chapters 2, 5, 6, 7 and appendix A, each registered in the report.

rule fig_tyre_curves:
    input:
        src("vehicle.single_track", "plots.data"),
    output:
        report(f"{FIG}/fig_2_3.png", caption="../report/fig_2_3.rst", category="Thesis 2 Vehicle model",
               labels={"figure": "Fig. 2.3", "content": "Magic-Formula tyre curves"}),
    params:
        **reads(surfaces="figures.tyre_surfaces"),
    threads: 1
    resources:
        mem_mb=1000,
        runtime=5,
    group: "figures"
    log:
        f"{OUT}/logs/fig_2_3.log",
    benchmark:
        f"{OUT}/benchmarks/fig_tyre_curves/fig_2_3.tsv",
    conda:
        "../envs/uqdrive.yaml"
    script:
        "../scripts/fig_tyre_curves.py"


rule fig_kle:
    input:
        src("plots.data"),
        kle=f"{OUT}/data/kle.nc",
    output:
        realisations=report(f"{FIG}/fig_5_2.png", caption="../report/fig_5_2.rst", category="Thesis 5 Wind and polynomial chaos",
                            subcategory="Wind KLE", labels={"figure": "Fig. 5.2", "content": "side-wind realisations"}),
        eigenfunctions=report(f"{FIG}/fig_7_1.png", caption="../report/fig_7_1.rst", category="Thesis 7 Wind KLE",
                              labels={"figure": "Fig. 7.1", "content": "KLE eigenfunctions"}),
    threads: 1
    resources:
        mem_mb=1000,
        runtime=5,
    group: "figures"
    log:
        f"{OUT}/logs/fig_kle.log",
    benchmark:
        f"{OUT}/benchmarks/fig_kle/fig_kle.tsv",
    conda:
        "../envs/uqdrive.yaml"
    script:
        "../scripts/fig_kle.py"


rule fig_data_band:
    input:
        src("plots.data"),
        stats=lambda w: f"{OUT}/data/stats_{'lst' if w.number == '1' else 'nlst'}_normal.nc",
    output:
        report(f"{FIG}/fig_6_{{number}}.png", caption="../report/fig_6_1_2.rst", category="Thesis 6.1 Measured data",
               labels=lambda w: {"figure": f"Fig. 6.{w.number}", "content": ("LST" if w.number == "1" else "NLST") + " data without noise"}),
    wildcard_constraints:
        number="1|2",
    params:
        **reads(band_sigmas="figures.band_sigmas"),
    threads: 1
    resources:
        mem_mb=1000,
        runtime=5,
    group: "figures"
    log:
        f"{OUT}/logs/fig_6_{{number}}.log",
    benchmark:
        f"{OUT}/benchmarks/fig_data_band/fig_6_{{number}}.tsv",
    conda:
        "../envs/uqdrive.yaml"
    script:
        "../scripts/fig_data_band.py"


rule fig_noise_levels:
    input:
        src("plots.data"),
        stats=lambda w: f"{OUT}/data/noise_stats_{'lst' if w.number == '3' else 'nlst'}.nc",
    output:
        report(f"{FIG}/fig_6_{{number}}.png", caption="../report/fig_6_3_4.rst", category="Thesis 6.1 Measured data",
               labels=lambda w: {"figure": f"Fig. 6.{w.number}", "content": ("LST" if w.number == "3" else "NLST") + " data per noise level"}),
    wildcard_constraints:
        number="3|4",
    threads: 1
    resources:
        mem_mb=1000,
        runtime=5,
    group: "figures"
    log:
        f"{OUT}/logs/fig_6_{{number}}.log",
    benchmark:
        f"{OUT}/benchmarks/fig_noise_levels/fig_6_{{number}}.tsv",
    conda:
        "../envs/uqdrive.yaml"
    script:
        "../scripts/fig_noise_levels.py"


rule fig_lst_vs_nlst:
    input:
        src("plots.data"),
        lst=f"{OUT}/data/stats_lst_normal.nc",
        nlst=f"{OUT}/data/stats_nlst_normal.nc",
        kl=f"{OUT}/data/kl_nlst_lst.nc",
    output:
        comparison=report(f"{FIG}/fig_6_5.png", caption="../report/fig_6_5.rst", category="Thesis 6.1 Measured data",
                          labels={"figure": "Fig. 6.5", "content": "LST against NLST"}),
        kl=report(f"{FIG}/fig_6_6.png", caption="../report/fig_6_6.rst", category="Thesis 6.1 Measured data",
                  labels={"figure": "Fig. 6.6", "content": "KL divergence NLST || LST"}),
    params:
        **reads(band_sigmas="figures.band_sigmas"),
    threads: 1
    resources:
        mem_mb=1000,
        runtime=5,
    group: "figures"
    log:
        f"{OUT}/logs/fig_6_5_6.log",
    benchmark:
        f"{OUT}/benchmarks/fig_lst_vs_nlst/fig_6_5_6.tsv",
    conda:
        "../envs/uqdrive.yaml"
    script:
        "../scripts/fig_lst_vs_nlst.py"


rule fig_appendix_a:
    # All of Figs A.1-A.2L in one job: a figure is a fraction of a second of drawing, a job of
    # its own as much again of Python start and imports (benchmarks/bench_job_overhead.py).
    input:
        src("plots.data"),
        lst=f"{OUT}/data/noise_stats_lst.nc",
        nlst=f"{OUT}/data/noise_stats_nlst.nc",
    output:
        # One row per noise level, LST/NLST as the toggle the report makes of a two-valued label.
        [report(f"{FIG}/fig_A{n}.png", caption="../report/fig_A.rst", category="Thesis appendix A Measured data",
                labels={"noise intensity A": str(NOISE_LEVELS[(n - 1) % N_LEVELS]), "model": appendix_a_model(n).upper()})
         for n in APPENDIX_A_ALL],
    params:
        figures=[(appendix_a_model(n), (n - 1) % N_LEVELS) for n in APPENDIX_A_ALL],
        **reads(band_sigmas="figures.band_sigmas"),
    threads: 1
    resources:
        mem_mb=1000,
        runtime=5,
    group: "figures"
    log:
        f"{OUT}/logs/fig_appendix_a.log",
    benchmark:
        f"{OUT}/benchmarks/fig_appendix_a/fig_appendix_a.tsv",
    conda:
        "../envs/uqdrive.yaml"
    script:
        "../scripts/fig_appendix_a.py"

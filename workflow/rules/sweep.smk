# Parameter sweeps (docs/workflow.md, "Changing and sweeping config values"). A sweep file config/sweeps/<name>.yaml
# names a base config, dotted keys with their values (grid or zip) and the metric groups to
# collect. Each point's resolved config is written to {OUT}/sweeps/<name>/<point>/config.yaml
# and this workflow runs on it into that folder (only the outputs the metrics need); the jobs
# whose settings match another point's come from a cache shared by the points. One summary
# (summary.nc, summary.csv, summary.png) gathers the points; it has a report category of its own.


wildcard_constraints:
    sweep=r"[A-Za-z0-9_.-]+",
    point=r"p\d+[^/]*",


rule sweep_config:
    input:
        src("studies.sweep.spec"),
        sweep=lambda w: str(sweep_file(w.sweep)),
        base=lambda w: sweep_base_file(w.sweep),
    output:
        f"{SWEEP_DIR}/{{sweep}}/{{point}}/config.yaml",
    params:
        config=lambda w, input: sweep(w.sweep).point_config(w.point, point_dir(w)),
        header=lambda w, input: f"Point {w.point} of sweep {w.sweep} ({_shown(input.sweep)}): {sweep(w.sweep).base_path} with "
        + ", ".join(f"{k} = {v}" for k, v in {**sweep(w.sweep).fixed, **sweep(w.sweep).point(w.point).values}.items()),
    threads: 1
    resources:
        mem_mb=1000,
        runtime=2,
    group: "sweep"
    log:
        f"{SWEEP_DIR}/{{sweep}}/{{point}}/logs/sweep_config.log",
    benchmark:
        f"{SWEEP_DIR}/{{sweep}}/{{point}}/benchmarks/sweep_config/sweep_config.tsv",
    conda:
        "../envs/uqdrive.yaml"
    script:
        "../scripts/sweep_config.py"


rule sweep_point:
    input:
        SWEEP_CODE,
        config=f"{SWEEP_DIR}/{{sweep}}/{{point}}/config.yaml",
    output:
        f"{SWEEP_DIR}/{{sweep}}/{{point}}/metrics.json",
    params:
        snakefile=lambda w, input: workflow.main_snakefile,
        outdir=lambda w, input: point_dir(w),
        collect=lambda w, input: list(sweep(w.sweep).collect),
        targets=lambda w, input: [f"{point_dir(w)}/{f}" for f in collect_targets(sweep(w.sweep).collect, sweep(w.sweep).point_config(w.point, point_dir(w)))],
        values=lambda w, input: sweep(w.sweep).point(w.point).values,
        cache=lambda w, input: f"{SWEEP_DIR}/.cache",
    threads: SWEEP_THREADS
    resources:
        mem_mb=4000,
        runtime=120,
    group: "sweep"
    log:
        f"{SWEEP_DIR}/{{sweep}}/{{point}}/logs/workflow.log",
    benchmark:
        f"{SWEEP_DIR}/{{sweep}}/{{point}}/benchmarks/sweep_point/workflow.tsv",
    conda:
        "../envs/uqdrive.yaml"
    script:
        "../scripts/sweep_point.py"


rule sweep_summary:
    input:
        src("studies.sweep.summary", "plots.sweep"),
        points=lambda w: [f"{SWEEP_DIR}/{w.sweep}/{p.name}/metrics.json" for p in sweep(w.sweep).points],
    output:
        nc=f"{SWEEP_DIR}/{{sweep}}/summary.nc",
        csv=report(f"{SWEEP_DIR}/{{sweep}}/summary.csv", caption="../report/sweep_summary.rst", category="uqdrive sweep {sweep}",
                   labels=lambda w: {"output": "summary table", "swept": ", ".join(sweep(w.sweep).keys)}),
        figure=report(f"{SWEEP_DIR}/{{sweep}}/summary.png", caption="../report/sweep_figure.rst", category="uqdrive sweep {sweep}",
                      labels=lambda w: {"output": "summary figure", "swept": ", ".join(sweep(w.sweep).keys)}),
    params:
        sweep=lambda w, input: sweep(w.sweep),
        file=lambda w, input: _shown(sweep_file(w.sweep)),
    threads: 1
    resources:
        mem_mb=1000,
        runtime=5,
    log:
        f"{SWEEP_DIR}/{{sweep}}/logs/summary.log",
    benchmark:
        f"{SWEEP_DIR}/{{sweep}}/benchmarks/sweep_summary/summary.tsv",
    conda:
        "../envs/uqdrive.yaml"
    script:
        "../scripts/sweep_summary.py"

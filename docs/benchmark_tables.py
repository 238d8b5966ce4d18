"""The benchmarks page's tables and quoted numbers, written at every docs build from the committed
records docs/measurements/benchmarks_*.json, with every ratio, share and sum computed here.

Each record names the command that produced it; refresh a record by rerunning that command and
replacing the numbers.
"""

from __future__ import annotations

import json
from pathlib import Path

from generated_tables import _write

RECORDS = Path(__file__).resolve().parent / "measurements"


def _rec(name: str) -> dict:
    return json.loads((RECORDS / f"benchmarks_{name}.json").read_text())


def _span(pair, fmt: str = "g") -> str:
    lo, hi = pair
    return f"{lo:{fmt}}" if lo == hi else f"{lo:{fmt}}-{hi:{fmt}}"


def _clock(seconds: float) -> str:
    return f"{int(seconds // 60)} min {int(seconds % 60)} s"


def montecarlo_table() -> str:
    r = _rec("montecarlo")
    lines = [f"| {r['runs']}-run ensemble | uqdrive | solve_ivp per realisation | speed-up | target |", "|---|---|---|---|---|"]
    lines += [f"| {x['model']} | {x['uqdrive_s']:g} s | {x['solve_ivp_s']:g} s | {x['solve_ivp_s'] / x['uqdrive_s']:.0f}x | "
              f"{x['target_speedup']}x |" for x in r["rows"]]
    return "\n".join(lines) + "\n"


def import_table() -> str:
    r = _rec("import")
    lines = [f"| logs | first call | best of {r['repeats']} | target |", "|---|---|---|---|"]
    lines += [f"| {x['logs']}, {x['size_mb']:.1f} MB | {x['first_s']:g} s | {x['best_s']:g} s | seconds, not minutes |" for x in r["rows"]]
    return "\n".join(lines) + "\n"


def reproduction_table() -> str:
    r = _rec("reproduction")
    total = r["job_seconds"]
    lines = ["| rule | jobs | job-seconds | share | longest job (s) | CPU-seconds |", "|---|---:|---:|---:|---:|---:|"]
    lines += [f"| {x['rule']} | {x['jobs']} | {x['job_seconds']} | {100 * x['job_seconds'] / total:.0f} % | {x['longest_s']} | {x['cpu_seconds']} |"
              for x in r["rules"]]
    o = r["other_rules"]
    lines.append(f"| {o['rules']} other rules | {o['jobs']} | {o['job_seconds']} | {100 * o['job_seconds'] / total:.0f} % | | |")
    jobs = sum(x["jobs"] for x in r["rules"]) + o["jobs"]
    lines.append(f"| **all** | {jobs} | {total} | | | {r['cpu_seconds']} |")
    return "\n".join(lines) + "\n"


def channel_detection_table() -> str:
    r = _rec("channel_detection")
    counts = " / ".join(str(n) for n in r["run_counts"])
    lines = [f"| channel set | CPU-s at {counts} runs | longest discover (wall, at that load) |", "|---|---|---|"]
    for c in r["columns"]:
        case = f" ({c['longest_case']})" if "longest_case" in c else ""
        lines.append(f"| {c['set']} | {' / '.join(str(s) for s in c['cpu_s'])} | {c['longest_wall_s']} s{case} |")
    return "\n".join(lines) + "\n"


def profile_batch_table() -> str:
    r = _rec("profile_batch")
    lines = ["| data (case: channel set: runs) | verdict | CPU-s before / after | ratio |", "|---|---|---|---:|"]
    lines += [f"| {x['data']} | {x['verdict']} | {x['before']:.1f} / {x['after']:.1f} | {x['before'] / x['after']:.2f} |" for x in r["rows"]]
    return "\n".join(lines) + "\n"


def discover_memo_table() -> str:
    r = _rec("discover_memo")
    lines = ["| data (case: channel set: runs) | verdict | CPU-s without / with | ratio | simulate() calls without / with |",
             "|---|---|---|---:|---|"]
    lines += [f"| {x['data']} | {x['verdict']} | {x['without']:.1f} / {x['with']:.1f} | {x['without'] / x['with']:.2f} | "
              f"{x['calls_without']} / {x['calls_with']} |" for x in r["rows"]]
    return "\n".join(lines) + "\n"


def pce_table() -> str:
    r = _rec("pce")
    lines = ["| LST, all uncertainties | time | error of mean | error of std |", "|---|---|---|---|"]
    lines += [f"| {x['method']} | {_span(x['time_ms'])} ms | {x['error_mean']:g} | {x['error_std']:g} |" for x in r["rows"]]
    return "\n".join(lines) + "\n"


def posterior_table() -> str:
    r = _rec("posterior")["jobs"]
    lines = ["| job | sequential | batched | speed-up |", "|---|---|---|---|"]
    for x in r["rows"]:
        note = f", {x['sequential_note']}" if "sequential_note" in x else ""
        lines.append(f"| {x['job']} | {x['sequential_cpu_s']} s ({x['sequential_wall_s']} s wall{note}) | "
                     f"{x['batched_cpu_s']} s ({x['batched_wall_s']} s wall) | {x['sequential_cpu_s'] / x['batched_cpu_s']:.1f}x |")
    return "\n".join(lines) + "\n"


def discover_default_table() -> str:
    r = _rec("discover_default")
    lines = ["| case | candidates | CPU s | wall s | verdict, gap before -> after |", "|---|---|---|---|---|"]
    cpu = lambda x: f"{x['cpu_s_before']:g} -> {x['cpu_s']:g}" if "cpu_s_before" in x else f"{x['cpu_s']:g}"  # noqa: E731
    lines += [f"| {x['case']} | {x['candidates']} | {cpu(x)} | {x['wall_s']} | {x['verdict']}, {x['gap'][0]:g} -> {x['gap'][1]:g} |"
              for x in r["rows"]]
    return "\n".join(lines) + "\n"


def chassis_table() -> str:
    r = _rec("chassis")
    lines = ["| structure | pairs | one simulate per pair (s) | simulate_many (s) | ratio | same numbers |", "|---|---|---|---|---|---|"]
    lines += [f"| {x['structure']} | {x['pairs']} | {x['one_by_one_s']:.2f} | {x['many_s']:.2f} | {x['one_by_one_s'] / x['many_s']:.2f} | "
              f"{'yes' if x['same'] else 'no'} |" for x in r["rows"]]
    return "\n".join(lines) + "\n"


def ltv_table() -> str:
    r = _rec("ltv")
    lines = ["| realisations | NumPy pass (s) | compiled pass (s) | ratio | same bits |", "|---|---|---|---:|---|"]
    lines += [f"| {x['realisations']} | {x['old_s']:.3f} | {x['new_s']:.4f} | {x['old_s'] / x['new_s']:.1f}x | {'yes' if x['same'] else 'no'} |"
              for x in r["rows"]]
    return "\n".join(lines) + "\n"


def load_loop_table() -> str:
    r = _rec("load_loop")
    lines = ["| tyre | loaded candidate | pairs | NumPy loop (s) | compiled loop (s) | ratio | same bits |", "|---|---|---|---:|---:|---:|---|"]
    lines += [f"| {x['tyre']} | {x['structure']} | {x['pairs']} | {x['numpy_s']:.2f} | {x['compiled_s']:.2f} | {x['numpy_s'] / x['compiled_s']:.2f}x | "
              f"{'yes' if x['same'] else 'no'} |" for x in r["rows"]]
    return "\n".join(lines) + "\n"


def fused_rates_table(record: str = "fused_rates") -> str:
    r = _rec(record)
    lines = ["| case | NumPy operations | compiled arithmetic | ratio | same numbers |", "|---|---:|---:|---:|---|"]
    for x in r["rows"]:
        call = x["case"].startswith("rhs")
        scale, unit = (1e6, " us") if call else (1.0, " CPU-s")
        lines.append(f"| {x['case']} | {x['numpy_s'] * scale:.1f}{unit} | {x['compiled_s'] * scale:.1f}{unit} | {x['ratio']:.2f}x | "
                     f"{'yes' if x['same'] else 'no'} |")
    return "\n".join(lines) + "\n"


def reproduce_jobs_table(record: str = "reproduce_jobs") -> str:
    r = _rec(record)
    lines = ["| job (rule: case) | verdict | CPU-s old / new | ratio | same verdict | numbers moved |", "|---|---|---|---:|---|---:|"]
    rule = {"discover": "discrepancy_discover", "cell": "discrepancy_channel_cell"}
    for x in r["rows"]:
        kind, name = x["job"].split(":", 1)
        named = "; ".join(", ".join(v.get("effects") or [str(v.get("effect", v.get("verdict")))]) for v in x["verdict"])
        lines.append(f"| {rule[kind]}: {name.replace(':', ': ')} | {named} | {x['old_cpu_s']:.1f} / {x['new_cpu_s']:.1f} | "
                     f"{x['old_cpu_s'] / x['new_cpu_s']:.2f} | {'yes' if x['same_verdict'] else 'no'} | {len(x['moved'])} |")
    return "\n".join(lines) + "\n"


def job_overhead_table() -> str:
    r = _rec("job_overhead")
    f = r["file"]
    lines = [f"| {f['case']}, {f['runs']} runs x {f['times']} times | write (s) | read (s) | MB |", "|---|---:|---:|---:|"]
    lines += [f"| {x['encoding']} | {x['write_s']:.3f} | {x['read_s']:.3f} | {x['mb']:.1f} |" for x in f["rows"]]
    return "\n".join(lines) + "\n"


def discover_jobs_table() -> str:
    r = _rec("discover_jobs")
    lines = ["| case | one process: wall (CPU) | workers | workers: wall (CPU) | wall ratio | same verdict |", "|---|---:|---:|---:|---:|---|"]
    lines += [f"| {x['case']} | {x['wall_1_s']:.0f} s ({x['cpu_1_s']:.0f} CPU-s) | {x['jobs']} | {x['wall_n_s']:.0f} s ({x['cpu_n_s']:.0f} CPU-s) | "
              f"{x['wall_1_s'] / x['wall_n_s']:.2f}x | {'yes' if x['same'] else 'no'} |" for x in r["rows"]]
    return "\n".join(lines) + "\n"


def memory_checks_table() -> str:
    r = _rec("memory_checks")
    lines = ["| case | LLVM's limits | uqdrive's limit | ratio | same numbers |", "|---|---:|---:|---:|---|"]
    for x in r["rows"]:
        if x["case"].startswith("rhs"):
            old, new = f"{x['llvm_s'] * 1e6:.1f} us", f"{x['uqdrive_s'] * 1e6:.1f} us"
        else:
            old, new = f"{x['llvm_s']:.0f} s ({x['cpu_llvm_s']:.0f} CPU-s)", f"{x['uqdrive_s']:.0f} s ({x['cpu_uqdrive_s']:.0f} CPU-s)"
        lines.append(f"| {x['case']} | {old} | {new} | {x['ratio']:.2f}x | {'yes' if x['same'] else 'no'} |")
    return "\n".join(lines) + "\n"


def chassis_programs_table() -> str:
    r = _rec("chassis_programs")
    lines = [f"| pass ({r['realisations']} realisations, {r['steps']} steps) | kernels per step: own program | shared program | "
             f"pass (s): own | shared |", "|---|---:|---:|---:|---:|"]
    lines += [f"| {x['pass']} | {x['own']['kernels_per_step']:g} | {x['shared']['kernels_per_step']:g} | {x['own']['pass_s']:.3f} | "
              f"{x['shared']['pass_s']:.3f} |" for x in r["rows"]]
    lines.append(f"| the NLST program, for scale | {r['nlst_kernels_per_step']:g} | | | |")
    return "\n".join(lines) + "\n"


TABLES = {"bench_montecarlo": montecarlo_table, "bench_import": import_table, "bench_reproduction": reproduction_table,
          "bench_channel_detection": channel_detection_table, "bench_profile_batch": profile_batch_table,
          "bench_discover_memo": discover_memo_table, "bench_pce": pce_table, "bench_posterior": posterior_table,
          "bench_discover_default": discover_default_table, "bench_chassis": chassis_table, "bench_reproduce_jobs": reproduce_jobs_table,
          "bench_reproduce_jobs_footing": lambda: reproduce_jobs_table("reproduce_jobs_footing"),
          "bench_ltv": ltv_table, "bench_job_overhead": job_overhead_table,
          "bench_load_loop": load_loop_table, "bench_fused_rates": fused_rates_table,
          "bench_fused_chassis": lambda: fused_rates_table("fused_chassis"), "bench_discover_jobs": discover_jobs_table,
          "bench_memory_checks": memory_checks_table, "bench_chassis_programs": chassis_programs_table}


def substitutions() -> dict[str, str]:
    """The numbers the benchmarks page quotes in its text, keyed ``bench_<record>_<what>``."""
    s: dict[str, str] = {}
    cp = _rec("chassis_programs")
    s.update(bench_chassis_programs_device=f"{cp['device']} (JAX {cp['jax']}, {cp['machine']})")
    mc = _rec("montecarlo")
    s.update(bench_mc_runs=str(mc["runs"]), bench_mc_baseline_runs=str(mc["baseline_runs"]), bench_mc_machine=mc["machine"],
             bench_mc_peak=f"{mc['peak_nlst_mib']} MiB", bench_mc_peak_target=f"{mc['peak_target_gib']} GiB")
    im = _rec("import")
    s.update(bench_import_runs=str(im["runs"]), bench_import_duration=f"{im['duration_s']} s",
             bench_import_rates=", ".join(str(h) for h in im["channel_rates_hz"]) + " Hz", bench_import_noise=f"{im['noise_percent']} %",
             bench_import_machine=im["machine"],
             bench_import_cpu="; ".join(f"{k} {v} s" for k, v in im["import_cpu_s"].items()))
    rp = _rec("reproduction")
    sc = rp["scorecard"]
    s.update(bench_repro_dag_jobs=str(rp["dag_jobs"]), bench_repro_machine=rp["machine"], bench_repro_job_seconds=str(rp["job_seconds"]),
             bench_repro_wall=_clock(rp["wall_s"]),
             bench_repro_cpu_seconds=str(rp["cpu_seconds"]),
             bench_repro_discover_share=f"{100 * next(x for x in rp['rules'] if x['rule'] == 'discrepancy_discover')['job_seconds'] / rp['job_seconds']:.0f} %",
             bench_repro_scorecard=f"{sc['rows']} rows, {sc['pass']} pass, {sc['deviate']} deviate, {sc['fail']} fail")
    cd = _rec("channel_detection")
    speed = sum(next(c for c in cd["columns"] if c["set"] == "imu_speed")["cpu_s"])
    prof = cd["profile"]
    s.update(bench_cd_machine=cd["machine"], bench_cd_cpu_total=str(cd["cpu_total_s"]), bench_cd_peak=f"{cd['peak_mb']} MB",
             bench_cd_speed_share=f"{100 * speed / cd['cpu_total_s']:.0f} %", bench_cd_one_cpu=str(cd["one_process"]["cpu_s"]),
             bench_cd_one_wall=f"{cd['one_process']['wall_min']} minutes", bench_cd_prof_cpu=str(prof["cpu_s"]),
             bench_cd_prof_load=prof["load"], bench_cd_prof_share=f"{prof['linear_rk4_percent']} %",
             bench_cd_prof_sims=str(prof["simulations"]), bench_cd_prof_realisations=str(prof["realisations"]),
             bench_cd_prof_baseline=f"{prof['baseline_fit_s']} s")
    pb = _rec("profile_batch")
    ahead = pb["neighbours_ahead"]
    fw = pb["four_wheel"]
    s.update(bench_pb_machine=pb["machine"], bench_pb_first_after=f"{pb['rows'][0]['after']:.1f}", bench_pb_ahead=f"{ahead['first_row_after']:.1f}",
             bench_pb_none20=f"{ahead['none_step_imu_speed_20']:.1f}",
             bench_pb_profile=", ".join(f"the {k} ({v} %)" for k, v in pb["profile_after_percent"].items()),
             bench_fw_runs=str(fw["runs"]), bench_fw_candidates=str(fw["candidates"]), bench_fw_cpu=f"{fw['before']:.1f} -> {fw['after']:.1f}",
             bench_fw_machine=fw["machine"], bench_fw_probe_share=f"{fw['probe_percent']} %",
             bench_fw_profile=", ".join(f"the {k} {v} %" for k, v in fw["profile_after_percent"].items()))
    s["bench_memo_machine"] = _rec("discover_memo")["machine"]
    s["bench_rj_machine"] = _rec("reproduce_jobs")["machine"]
    s["bench_rjf_machine"] = _rec("reproduce_jobs_footing")["machine"]
    pce = _rec("pce")
    pce2, pce3, mcrow = pce["rows"]
    s.update(bench_pce_reference_runs=f"{pce['reference_runs']:,}".replace(",", " "), bench_pce_setup=f"{pce['setup_ms']} ms",
             bench_pce_vs_mc=f"{mcrow['time_ms'][0] / pce2['time_ms'][1]:.0f}-{mcrow['time_ms'][1] / pce2['time_ms'][0]:.0f}x",
             bench_pce_equal_error=_span(pce["equal_error_speedup"]) + "x",
             bench_pce_mc_mean_runs=f"{pce['mc_runs_equal_error']['mean']:,}".replace(",", " "),
             bench_pce_mc_std_runs=f"{pce['mc_runs_equal_error']['std']:,}".replace(",", " "),
             bench_pce_solve_ivp=f"{pce['solve_ivp_speedup']:,}x".replace(",", " "), bench_pce_target=f"{pce['target_speedup']}x",
             bench_pce3=f"{pce['npce3_equal_std_speedup']}x", bench_pce3_vs4=f"{pce['npce3_error_vs_npce4']:g}",
             bench_pce_time=f"{pce2['time_ms'][0]:g} ms",
             bench_pce_breakdown=", ".join(f"{k} {v:g} ms" for k, v in pce["breakdown_ms"].items()))
    idf = _rec("identify")
    si, uf = idf["si"], idf["unit_free"]
    s.update(bench_id_moments=f"{idf['moments_ms']:g} ms", bench_id_sens=f"{_span(idf['sensitivities_ms'])} ms",
             bench_id_adjoint=f"{idf['adjoint_ms']:g} ms", bench_id_params=str(idf["parameters"]), bench_id_germs=str(idf["germs"]),
             bench_id_times=str(idf["times"]),
             bench_id_si=(f"L-BFGS-B + adjoint {si['lbfgsb_adjoint_s']:.2f} s ({si['lbfgsb_adjoint_iterations']} iterations), "
                          f"Gauss-Newton {si['gauss_newton_s']:.2f} s ({si['gauss_newton_iterations']}), L-BFGS-B with finite "
                          f"differences {si['lbfgsb_fd_s']:.2f} s ({si['lbfgsb_fd_evaluations']} evaluations): "
                          f"{si['lbfgsb_fd_s'] / si['lbfgsb_adjoint_s']:.1f}x and {si['lbfgsb_fd_s'] / si['gauss_newton_s']:.1f}x, "
                          f"same optimum to {si['optimum_tolerance']:g}"),
             bench_id_unit_free=f"{uf['lbfgsb_adjoint_s']:.2f} s and {uf['gauss_newton_s']:.2f} s",
             bench_id_fd_cost=f"{_span(uf['fd_cost'])} vs {uf['optimum_cost']:g}", bench_id_target=f"{idf['target_speedup']}x",
             bench_id_fd_evals=str(idf["parameters"] + 1),
             bench_id_adjoint_evals=f"{idf['adjoint_ms'] / idf['moments_ms']:.1f}",
             bench_id_sens_evals=f"{sum(idf['sensitivities_ms']) / 2 / idf['moments_ms']:.1f}",
             bench_id_iter_ratio=f"{si['lbfgsb_adjoint_iterations'] / si['gauss_newton_iterations']:.0f}x")
    po = _rec("posterior")
    s.update(bench_post_scalar=f"{po['scalar_ms']:.1f} ms",
             bench_post_batches=", ".join(f"batches of {b['size']} {b['ms']:g} ms ({po['scalar_ms'] / b['ms']:.1f}x)" for b in po["batches"]),
             bench_post_sampling=f"a short sampling run of {po['sampling_ensembles']} ensembles {po['sampling_speedup']:g}x")
    dc = _rec("discover")
    pc = dc["per_case"]
    s.update(bench_disc_case=f"{_span(pc['case_s'])} s", bench_disc_thesis=f"{pc['thesis_case_s']} s", bench_disc_case_machine=pc["machine"],
             bench_disc_runs=str(dc["runs"]), bench_disc_wall=f"{dc['wall_s']:.1f} s", bench_disc_cpu=f"{dc['cpu_s']:.1f} s",
             bench_disc_budget=f"{dc['budget_s'] / 60:g}-minute", bench_disc_ratio=f"{dc['wall_s'] / dc['budget_s']:.2f}")
    dd = _rec("discover_default")
    b = dd["braking"]
    s.update(bench_dd_braking_runs=str(b["runs"]), bench_dd_speeds=f"{b['speed_from_mps']} to {b['speed_to_mps']} m/s",
             bench_dd_reality_h=f"{b['reality_cg_height_m']:g} m", bench_dd_vehicle_h=f"{b['vehicle_cg_height_m']:g}",
             bench_dd_tour_runs=str(dd["tour"]["runs"]), bench_dd_machine=dd["machine"], bench_dd_side_by_side=dd["side_by_side"])
    ch = _rec("chassis")
    s.update(bench_chassis_realisations=str(ch["realisations"]), bench_chassis_duration=f"{ch['duration_s']} s", bench_chassis_machine=ch["machine"])
    ll = _rec("load_loop")
    s.update(bench_ll_machine=ll["machine"], bench_ll_realisations=str(ll["realisations"]), bench_ll_duration=f"{ll['duration_s']:g} s")
    s["bench_fr_machine"] = _rec("fused_rates")["machine"]
    s["bench_fc_machine"] = _rec("fused_chassis")["machine"]
    mk = _rec("memory_checks")
    s.update(bench_mchk_machine=mk["machine"], bench_mchk_llvm=" and ".join(str(v) for v in mk["llvm_limits"].values()))
    jobs = _rec("discover_jobs")
    s["bench_dj_machine"] = f"{jobs['machine']}, {jobs['cpus']} CPUs"
    lt = _rec("ltv")
    cells = lt["cells"]
    s.update(bench_ltv_machine=lt["machine"], bench_ltv_duration=f"{lt['duration_s']:g} s", bench_ltv_steps=str(lt["steps"]),
             bench_ltv_compile=f"{lt['compile_s']:g} s", bench_ltv_cached_load=f"{lt['cached_load_s']:g} s",
             bench_ltv_import=f"{lt['numba_import_s']:g} s", bench_ltv_cells_machine=cells["machine"],
             bench_ltv_cells="; ".join(f"{x['data']} {x['before']:.1f} -> {x['after']:.1f} ({x['before'] / x['after']:.2f}x)" for x in cells["rows"]))
    jo = _rec("job_overhead")
    deflate, plain = jo["file"]["rows"]
    s.update(bench_jo_machine=jo["machine"], bench_jo_starts="; ".join(f"{x['job']} {x['seconds']:g} s" for x in jo["starts"]),
             bench_jo_kept=f"{100 * deflate['mb'] / plain['mb']:.0f} %", bench_jo_write=f"{deflate['write_s'] / plain['write_s']:.0f}x")
    sw = _rec("sweeps")["seconds"]
    s["bench_sweeps"] = ", ".join(f"{_clock(v)} for `{k}`" for k, v in sw.items())
    ts = _rec("test_suite")
    cpu = ts["cpu_s"]
    s.update(bench_ts_latest_total=_clock(ts["total_s"]), bench_ts_latest_tests=str(ts["tests"]), bench_ts_latest_pytest=_clock(ts["pytest_s"]),
             bench_ts_latest_machine=ts["machine"], bench_ts_before=_clock(ts["pytest_runs_s"][0]),
             bench_ts_after=" and ".join(_clock(v) for v in ts["pytest_runs_s"][1:]),
             bench_ts_spread=f"{_clock(min(ts['earlier_pytest_runs_s']))} to {_clock(max(ts['earlier_pytest_runs_s']))}",
             bench_ts_runs=str(len(ts["earlier_pytest_runs_s"])),
             bench_ts_cpu=f"each DAG run of config/test.yaml ~{_span(cpu['dag_run'], '.0f')} CPU-s (Snakemake's own process ~{cpu['snakemake_process']:.0f} of it), "
                          f"the unit tests ~{cpu['unit_one_core']:.0f} CPU-s on one core with numba's kernels compiled, their first compilation "
                          f"~{cpu['numba_first_compile']:.0f} CPU-s more (a clean clone compiles them during the suite), the documentation build ~{cpu['docs']:.0f} CPU-s",
             bench_ts_import_graph=f"{ts['import_graph_s'][0]:g} -> {ts['import_graph_s'][1]:g} s")
    return s


def write_all(outdir: Path) -> None:
    """Write every table of the benchmarks page into ``outdir``."""
    for name, table in TABLES.items():
        _write(outdir / f"{name}.md", table())

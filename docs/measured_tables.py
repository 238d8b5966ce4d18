"""Tables of measurements that no docs build can repeat (benchmarks of hours, a cluster run), written
at every build from the committed records in docs/measurements/, with whatever the code defines
(declared resources, binomial bands, sampling errors) computed here, not copied.

Each record is what its tool prints or returns, saved as it came: refresh a record by rerunning
the tool named in the record's section of the page and replacing the file.
"""

from __future__ import annotations

import importlib.util
import json
import math
from pathlib import Path

import benchmark_tables
import reproduction_tables
from generated_tables import _write  # one writer that leaves unchanged pages to Sphinx's cache

HERE = Path(__file__).resolve().parent
RECORDS = HERE / "measurements"


def _load(name: str):
    path = RECORDS / name
    if path.suffix == ".jsonl":
        return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]
    return json.loads(path.read_text())


def _tool(root: Path, name: str):
    spec = importlib.util.spec_from_file_location(name, root / "tools" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _truth_std() -> float:
    from uqdrive.config import load_config

    return float(load_config(None)["uncertainty"]["mu"]["std"])


def channels_table() -> str:
    """The identification error per channel set and run count (benchmarks/bench_channels.py's
    JSON lines), the runs' own sampling error beside it, and what the table says of the
    standard errors, computed from the record."""
    rows = _load("bench_channels.jsonl")
    sigma = _truth_std()
    sets = list(dict.fromkeys(r["set"] for r in rows))
    counts = sorted({r["runs"] for r in rows})
    lines = ["| channels | runs | mu mean: error | mu mean: SE | mu std: error | mu std: SE | converged |",
             "|---|---:|---:|---:|---:|---:|---:|"]
    for r in sorted(rows, key=lambda r: (sets.index(r["set"]), r["runs"])):
        lines.append(f"| {r['set']} | {r['runs']} | {r['mu_mean_error']:.4f} | {r['mu_mean_se']:.4f} | {r['mu_std_error']:.4f} | "
                     f"{r['mu_std_se']:.4f} | {r['converged']} |")
    own_mean = ", ".join(f"{sigma / math.sqrt(n):.2g} ({n})" for n in counts)
    own_std = ", ".join(f"{sigma / math.sqrt(2 * (n - 1)):.2g}" for n in counts)
    se_at = {n: max(r["mu_mean_se"] for r in rows if r["runs"] == n) for n in counts}
    worst_mean = max(r["mu_mean_error"] / r["mu_mean_se"] for r in rows)
    worst_std = max(r["mu_std_error"] / r["mu_std_se"] for r in rows)
    failed = [f"{r['set']} at {r['runs']} runs ({r['converged']})" for r in rows
              if r["converged"].split("/")[0] != r["converged"].split("/")[1]]
    text = [
        "",
        f"For comparison, the sampling error of the runs' own mean of mu, {sigma:g}/sqrt(n): {own_mean} runs; of "
        f"their std, {sigma:g}/sqrt(2 (n - 1)): {own_std}."
        + (f" Not every fit converged: {', '.join(failed)}." if failed else ""),
        "",
        f"The reported standard errors of mu's mean run from {se_at[counts[0]]:.2g} at {counts[0]} runs to "
        f"{se_at[counts[-1]]:.2g} at {counts[-1]} ({sigma:g}/sqrt(n): {sigma / math.sqrt(counts[0]):.2g} to "
        f"{sigma / math.sqrt(counts[-1]):.2g}); the errors of mu's mean lie within {worst_mean:.2g} SE in every cell, "
        f"those of its std within {worst_std:.2g} SE.",
    ]
    return "\n".join(lines + text) + "\n"


def coverage_table() -> str:
    """The calibration of identify's intervals (benchmarks/identify_coverage.py's rates), each
    with the 99 % binomial band of its replicate count computed here."""
    from uqdrive.studies.identification import binomial_band

    rec = _load("identify_coverage.json")
    lines = [f"Replicates on a {rec['dt']:g} s grid ("
             + ", ".join(f"{k} data sets of {n} realisations" for n, k in rec["replicates"].items())
             + "; the thesis' distributions of mu, l_f and the mean wind, m_load known, no gusts):", "",
             "| realisations | parameter | coverage of the 95 % interval | 99 % binomial band | spread of the estimates / mean standard error |",
             "|---|---|---|---|---|"]
    rates = []
    for r in rec["rows"]:
        k = rec["replicates"][str(r["runs"])]
        misfit = r["spread_over_se"] is None
        lo, hi = binomial_band(k, 0.99 if misfit else 0.95, 0.01)
        name = "misfit passes the 99 % test" if misfit else r["parameter"]
        spread = "" if misfit else f"{r['spread_over_se']:.2f}"
        lines.append(f"| {r['runs']} | {name} | {r['coverage_95']:.3f} | [{lo:.3f}, {hi:.3f}] | {spread} |")
        if not misfit:
            rates.append(r["coverage_95"])
    lines += ["", f"The rates of the parameters average {sum(rates) / len(rates):.2f}."]
    return "\n".join(lines) + "\n"


def _minutes(seconds: float) -> str:
    return f"{seconds:.0f} s" if seconds < 60 else f"{seconds / 60:.1f} min"


def resources_tables(root: Path) -> tuple[str, str]:
    """The per-rule table of the full config's run (its measured peaks against what the rules
    declare now, read from workflow/rules) and the per-group table of the CI-sized Slurm run."""
    declared = _tool(root, "rule_resources").declared()
    rec = _load("rule_resources.json")
    full = rec["full"]
    lines = ["| rule | jobs | peak MB | declared MB | longest job | declared runtime |", "| --- | ---: | ---: | ---: | ---: | ---: |"]
    for rule, m in full["rules"].items():
        mem, runtime = declared[rule]
        lines.append(f"| {rule} | {m['jobs']} | {m['max_rss']:.0f} | {mem:.0f} | {_minutes(m['seconds'])} | {runtime:.0f} min |")
    others = full["other_rules"]
    lines += ["", f"Every other rule's job held at most {others['max_rss']:.0f} MB and ran at most {_minutes(others['seconds'])}."]
    groups = ["| group job | peak MB (batch + largest step) | asked MB | elapsed | time limit |", "| --- | --- | --- | --- | --- |"]
    groups += [f"| {g['group']} | {g['peak_mb']} | {g['asked_mb']} | {g['elapsed']} | {g['limit']} |" for g in rec["ci"]["groups"]]
    return "\n".join(lines) + "\n", "\n".join(groups) + "\n"


def _clock(seconds: float) -> str:
    return f"{int(seconds // 60)} min {int(seconds % 60)} s" if seconds >= 60 else f"{seconds:.0f} s"


def slurm_steps_table() -> str:
    """The CI run's three Slurm runs (interrupted, cancelled, to the end) with their sum, and the
    whole CI run's time."""
    rec = _load("rule_resources.json")["ci"]["slurm_steps"]
    lines = [f"In CI ({rec['machine']}):", "", "| Slurm run | wall time | jobs | submissions |", "| --- | ---: | ---: | ---: |"]
    lines += [f"| {s['step']} | {s['seconds']} s | {s['jobs']} | {s['submissions']} |" for s in rec["steps"]]
    total = {k: sum(s[k] for s in rec["steps"]) for k in ("seconds", "jobs", "submissions")}
    lines.append(f"| on Slurm in all | {total['seconds']} s | {total['jobs']} | {total['submissions']} |")
    lines += ["", f"The whole CI run took {_clock(rec['ci_total_seconds'])} (pytest {_clock(rec['pytest_seconds'])}), "
              f"the failing-rule test {_clock(rec['failing_rule_seconds'])}."]
    return "\n".join(lines) + "\n"


def substitutions(root: Path) -> dict[str, str]:
    """The numbers the cluster, benchmarks and reproduction pages quote in their text, from the records, the rules and the lock file."""
    rr = _tool(root, "rule_resources")
    declared = rr.declared()
    ci = _load("rule_resources.json")["ci"]
    over = ci["slurm_overhead_mb"]
    mems = sorted(m for m, _ in declared.values())
    times = sorted(t for _, t in declared.values())
    lock = dict(line.split("==", 1) for line in (root / "requirements.lock").read_text().splitlines() if "==" in line)
    return {"snakemake_version": lock["snakemake"], "slurm_plugin_version": lock["snakemake-executor-plugin-slurm"],
            "ci_peak_mb": f"{ci['peak_mb'][0]}-{ci['peak_mb'][1]}",
            "ci_largest": f"{ci['largest']['rule']}: {ci['largest']['max_rss']} MB, {ci['largest']['seconds']} s",
            "declared_mb": f"{mems[0]:.0f}-{mems[-1]:.0f}", "declared_min": f"{times[0]:.0f}-{times[-1]:.0f}",
            "group_overhead_mb": str(over["group_snakemake"] + over["srun_snakemake"]),
            "group_snakemake_mb": str(over["group_snakemake"]), "srun_snakemake_mb": str(over["srun_snakemake"]),
            "job_alone_mb": str(over["job_alone"]), "rule_process_mb": str(over["rule_process"]),
            "memory_margin": f"{rr.MEMORY_MARGIN:g}", "runtime_margin": f"{rr.RUNTIME_MARGIN:g}",
            "groups_machine": ci["groups_machine"], "full_machine": _load("rule_resources.json")["full"]["machine"],
            **benchmark_tables.substitutions(), **reproduction_tables.substitutions()}


def write_all(root: Path, outdir: Path) -> None:
    """Write every table of this module into ``outdir``."""
    _write(outdir / "bench_channels.md", channels_table())
    _write(outdir / "identify_coverage.md", coverage_table())
    rules, groups = resources_tables(root)
    _write(outdir / "rule_resources_full.md", rules)
    _write(outdir / "rule_resources_ci_groups.md", groups)
    _write(outdir / "slurm_steps.md", slurm_steps_table())
    benchmark_tables.write_all(outdir)
    reproduction_tables.write_all(outdir)

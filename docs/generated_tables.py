"""Tables of the guides written from the code at every docs build: the candidate effects of
discover (the registry) and the workflow's rules, so that no page types what the code defines.
"""

from __future__ import annotations

import functools
import math
import re
from pathlib import Path

import yaml


def _cell(text: str) -> str:
    return " ".join(str(text).split()).replace("|", "\\|")


def _percent(x: float, digits: int = 0) -> str:
    return f"{100 * x:.{digits}f} %"


def _bound(lo: float, hi: float) -> str:
    return f"{lo:g} to {hi:g}"


def candidates_table() -> str:
    """Markdown table of every registered candidate effect, one row per effect (a sensor family
    one row for all its channels), with its parameters, the value at which it vanishes, whether
    the packaged config searches it, what it models and what it moves first."""
    import uqdrive
    from uqdrive.vehicle import effects as fx

    default = yaml.safe_load((Path(uqdrive.__file__).resolve().parent / "default_config.yaml").read_text())
    searched = set(fx.expand_names(default["discrepancy"]["candidates"]))
    family_of = {m: fam for fam, members in fx.FAMILIES.items() for m in members}
    lines = ["| name | parameters (unit, bounds, start) | vanishes at | searched by default | what it models | what it moves first |",
             "|---|---|---|---|---|---|"]
    done: set[str] = set()
    for name, e in fx.EFFECTS.items():
        family = family_of.get(name)
        if family in done:
            continue
        if family:
            done.add(family)
            members = [fx.EFFECTS[m] for m in fx.FAMILIES[family]]
            channels = ", ".join(m.channel for m in members)
            units = ", ".join(f"{m.channel}: {m.units[0]}" for m in members)
            row = (f"`{family}_<channel>` (channel: {channels})",
                   f"{members[0].parameters[0].rsplit('_', 1)[0]}_<channel> ({units}; start {members[0].start[0]:g})",
                   f"{fx.VANISHES[members[0].name][1]:g}",
                   "yes" if all(m.name in searched for m in members) else "no",
                   members[0].description.replace(members[0].channel, "channel"),
                   members[0].signature.replace(f"{members[0].channel}:", "the channel:"))
        else:
            params = "; ".join(f"{p} ({u}, {_bound(*b)}, start {s:g})"
                               for p, u, b, s in zip(e.parameters, e.units, e.bounds, e.start))
            vanish = fx.VANISHES.get(name)
            row = (f"`{name}`", params, f"{vanish[0]} = {vanish[1]:g}" if vanish else "never (differs at every value)",
                   ("yes" + (f", when the car gives {' and '.join(e.requires)}" if e.requires else "")) if name in searched else "no",
                   e.description, e.signature)
        lines.append("| " + " | ".join(_cell(c) for c in row) + " |")
    return "\n".join(lines) + "\n"


def workflow_rules(root: Path) -> str:
    """Markdown sentence and table: the rule files of the workflow and the rules each defines."""
    files = [root / "Snakefile", root / "workflow" / "Snakefile"] + sorted((root / "workflow" / "rules").glob("*.smk"))
    rows, total = [], 0
    for f in files:
        names = re.findall(r"^rule\s+(\w+)\s*:", f.read_text(), flags=re.MULTILINE)
        if names:
            total += len(names)
            rows.append(f"| `{f.relative_to(root)}` | {len(names)} | " + ", ".join(f"`{n}`" for n in names) + " |")
    head = [f"The workflow defines {total} rules in {len(rows)} files (counted from `workflow/` "
            "when these pages were built); a rule runs once per case, seed or sweep cell, so the job count "
            "depends on the config: `snakemake -n --quiet rules --configfile FILE` prints it for yours.", "",
            "| file | rules | names |", "|---|---:|---|"]
    return "\n".join(head + rows) + "\n"


def _write(out: Path, text: str) -> None:
    out.parent.mkdir(parents=True, exist_ok=True)
    if not out.exists() or out.read_text() != text:  # unchanged file: Sphinx keeps its cache
        out.write_text(text)


def write_all(root: Path, outdir: Path) -> None:
    """Write every table of this module into ``outdir``."""
    _write(outdir / "candidates.md", candidates_table())
    _write(outdir / "workflow_rules.md", workflow_rules(root))
    _write(outdir / "four_wheel_car.md", four_wheel_car())
    _write(outdir / "four_wheel_cases.md", four_wheel_cases(root))
    _write(outdir / "four_wheel_results.md", four_wheel_results(root))
    _write(outdir / "plausible_car.md", plausible_car())
    _write(outdir / "gpu_ensembles.md", gpu_ensembles(root / "docs" / "measurements" / "gpu.json"))
    _write(outdir / "real_tyres_cases.md", real_tyres(root, "cases"))
    _write(outdir / "real_tyres_results.md", real_tyres(root, "results"))
    _write(outdir / "real_tyres_cars.md", real_tyres(root, "cars"))
    _write(outdir / "model_realisations.md", model_realisations_table(root))


def model_realisations_table(root: Path) -> str:
    """Markdown table of discover's linear-model realisations at the workflow's run counts (the
    detection table's and the benchmark's), at ``model_ratio`` 0 and at the workflow's ratio, with
    the model's share n / M of the compared statistics' variance and the part (1 + n/M_0) / (1 + n/M)
    of a gap's chi2 excess kept."""
    from uqdrive.settings.run import model_realisations

    d = yaml.safe_load((root / "config" / "config.yaml").read_text())["discrepancy"]
    cap, floor, ratio = d["model_samples"], d["nonlinear_samples"], d["model_ratio"]
    runs = sorted({*d["channel_sets"]["runs"], d["benchmark"]["samples"]})
    lines = [f"| runs n | M at ratio 0 | n / M | M at ratio {ratio:g} | n / M | gap's chi2 excess kept |", "|---|---|---|---|---|---|"]
    for n in runs:
        m0, m = model_realisations(n, cap, floor, 0), model_realisations(n, cap, floor, ratio)
        lines.append(f"| {n} | {m0} | {_percent(n / m0)} | {m} | {_percent(n / m)} | {_percent((1 + n / m0) / (1 + n / m))} |")
    return "\n".join(lines) + "\n"


def substitutions() -> dict[str, str]:
    """Numbers the pages quote through MyST substitutions (``{{ name }}``), read from the code and
    the packaged config."""
    from uqdrive import io
    from uqdrive.vehicle import effects as fx

    config = yaml.safe_load((Path(io.__file__).resolve().parent / "default_config.yaml").read_text())
    return {"min_runs": str(io.MIN_RUNS),
            "spin_threshold": f"{config['montecarlo']['spin_threshold']:g}",
            "discover_level": f"{config['discrepancy']['level']:g}",
            "max_effects": str(config["discrepancy"]["max_effects"]),
            "n_effects": str(len(fx.EFFECTS)),
            "mu_prior": "N({mean:g}, {std:g})".format(**config["uncertainty"]["mu"]),
            **_model_ratio_substitutions(Path(io.__file__).resolve().parents[2] / "config" / "config.yaml"),
            "locked_packages": str(sum(1 for line in (Path(io.__file__).resolve().parents[2] / "requirements.lock").read_text().splitlines()
                                       if "==" in line))}


def _model_ratio_substitutions(workflow_config: Path) -> dict[str, str]:
    """The workflow's ``discrepancy.model_ratio`` r, the model's largest share 1/r of the variance,
    the scale's widening sqrt(1 + 1/r) - 1 and the run count model_samples / r from which r
    changes nothing."""
    d = yaml.safe_load(workflow_config.read_text())["discrepancy"]
    r = d["model_ratio"]
    return {"workflow_model_ratio": f"{r:g}", "model_ratio_share": _percent(1 / r), "model_ratio_widening": _percent((1 + 1 / r) ** 0.5 - 1, 1),
            "model_ratio_full_runs": str(math.ceil(d["model_samples"] / r))}


def four_wheel_car() -> str:
    """Markdown table of the four-wheel car's constants (`FourWheelCar` defaults) with their
    meaning and unit from its docstring."""
    import dataclasses

    from uqdrive.vehicle.four_wheel import FourWheelCar

    from numpydoc.docscrape import NumpyDocString

    defaults = {f.name: f.default for f in dataclasses.fields(FourWheelCar)}
    lines = ["| constants | default values | meaning (units, in the order of the constants) |", "|---|---|---|"]
    for p in NumpyDocString(FourWheelCar.__doc__)["Attributes"]:
        names = [n.strip() for n in p.name.split(",") if n.strip() in defaults]
        values = ", ".join(f"{defaults[n]:g}" for n in names)
        lines.append(f"| {', '.join(f'`{n}`' for n in names)} | {values} | {_cell(' '.join(p.desc))} |")
    return "\n".join(lines) + "\n"


@functools.lru_cache(maxsize=None)
def _bench(root: Path, name: str):
    """The benchmark script ``root``/benchmarks/``name``.py as a module, with the scripts' folder on
    the import path (as when it runs: the scripts import their shared helpers by name)."""
    import importlib.util
    import sys

    folder = str(root / "benchmarks")
    if folder not in sys.path:
        sys.path.append(folder)
    spec = importlib.util.spec_from_file_location(name, root / "benchmarks" / f"{name}.py")
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    return bench


def four_wheel_results(root: Path) -> str:
    """Markdown results table of the four-wheel benchmark from the committed docs/four_wheel.json,
    each verdict judged against the reality (benchmarks/bench_four_wheel.py)."""
    import json

    return _bench(root, "bench_four_wheel").table(json.loads((root / "docs" / "four_wheel.json").read_text())) + "\n"


def four_wheel_cases(root: Path) -> str:
    """Markdown table of the four-wheel benchmark's cases with the expectation that
    benchmarks/bench_four_wheel.py states for each."""
    from uqdrive.studies.four_wheel import four_wheel_cases as cases

    bench = _bench(root, "bench_four_wheel")
    lines = ["| case | input | level (of the steady limit) | duration (s) | expected named set (order free) |", "|---|---|---:|---:|---|"]
    for c in cases({"seed": 0}):
        params = ", ".join(f"{k} {v}" for k, v in dict(c.manoeuvre_params).items())
        lines.append(f"| `{c.name}` | {c.manoeuvre}{f' ({params})' if params else ''} | {c.level:g} | {c.t_end:g} | "
                     f"{_cell(bench.EXPECTED.get(c.name, ''))} |")
    return "\n".join(lines) + "\n"


def real_tyres(root: Path, part: str) -> str:
    """The real-tyres benchmark's cases with the expectation benchmarks/bench_real_tyres.py states
    for each (``part`` "cases"), its results table from the committed docs/real_tyres.json
    ("results"), or each car's constants that differ from the sedan's ("cars")."""
    import json

    from dataclasses import asdict

    from uqdrive.studies.real_tyres import CARS, real_tyre_cases

    bench = _bench(root, "bench_real_tyres")
    if part == "results":
        return bench.table(json.loads((root / "docs" / "real_tyres.json").read_text())) + "\n"
    if part == "cars":
        sedan = asdict(CARS["sedan"])
        lines = ["| car | constants other than the sedan's |", "|---|---|"]
        for name, car in CARS.items():
            own = {k: v for k, v in asdict(car).items() if sedan.get(k) != v}
            lines.append(f"| `{name}` | {', '.join(f'{k} {v:.4g}' for k, v in own.items()) or '(the sedan)'} |")
        return "\n".join(lines) + "\n"
    lines = ["| case | car | input | level (of the steady limit) | duration (s) | expected named set (order free) |", "|---|---|---|---:|---:|---|"]
    for c in real_tyre_cases({"seed": 0}):
        params = ", ".join(f"{k} {v}" for k, v in dict(c.manoeuvre_params).items())
        lines.append(f"| `{c.name}` | `{c.car}` | {c.manoeuvre} ({params}) | {c.level:g} | {c.t_end:g} | {_cell(bench.EXPECTED[c.name])} |")
    return "\n".join(lines) + "\n"


def plausible_car() -> str:
    """Markdown table of the plausibility checks of a vehicle file (`uqdrive.vehicle_spec.PLAUSIBLE`):
    the range a car's number must lie in and the unit slip named when it does not."""
    from uqdrive.vehicle_spec import PLAUSIBLE

    lines = ["| key | accepted range | unit | below it, the message asks | above it, the message asks |", "|---|---|---|---|---|"]
    for key, (lo, hi, unit, below, above) in PLAUSIBLE.items():
        slip = lambda s: f"given in {s[0]}?" if s else "-"  # noqa: E731
        lines.append(f"| `{key}` | {lo:g} to {hi:g} | {unit} | {slip(below)} | {slip(above)} |")
    return "\n".join(lines) + "\n"


def gpu_ensembles(measured: Path) -> str:
    """Markdown sentence and table of the GPU benchmark's record (benchmarks/bench_gpu.py --json):
    the machine it names, each ensemble size's times and the JAX path's difference from NumPy's."""
    import json

    record = json.loads(measured.read_text())
    m = record["machine"]

    def seconds(row, key):
        value = row.get(key)
        return "-" if value is None else (f"{value * 1e3:.1f} ms" if value < 1 else f"{value:.2f} s")

    head = [f"Measured on {m['device']} (JAX {m['jax']}, platform `{m['platform']}`, NumPy {m['numpy']} on the same "
            f"machine's CPU, Python {m['python']}), {m['date']}, with `{record['command']}`: {record['t_end_s']:g} s of "
            f"the NLST, RK4 at {record['step_s'] * 1e3:g} ms ({record['steps']} steps), float64, best of "
            f"{record['repeats']} (the NumPy path and the whole `simulate_ensemble` above 2000 runs: one call). A dash: not "
            "timed at that size.", "",
            "| runs | JAX kernel | + copy to the host | NumPy kernel | kernel speed-up | JAX `simulate_ensemble` | "
            "NumPy `simulate_ensemble` | compile | largest relative difference |",
            "|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    rows = []
    for r in record["rows"]:
        speedup = f"{r['speedup_kernel']:.0f}x" if "speedup_kernel" in r else "-"
        diff = f"{r['max_relative_difference']:.1e}" if "max_relative_difference" in r else "-"
        rows.append(f"| {r['runs']} | {seconds(r, 'jax_kernel_s')} | {seconds(r, 'jax_kernel_to_host_s')} | "
                    f"{seconds(r, 'numpy_kernel_s')} | {speedup} | {seconds(r, 'jax_ensemble_s')} | "
                    f"{seconds(r, 'numpy_ensemble_s')} | {seconds(r, 'jax_compile_s')} | {diff} |")
    return "\n".join(head + rows) + "\n"

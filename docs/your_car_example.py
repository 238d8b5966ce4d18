"""The worked example of the your-car guide, run at every docs build: an ensemble of the textbook
sedan, identified with its own constants and with another car's, the console output and the
numbers the page quotes written as Markdown.
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import tempfile
import warnings
from pathlib import Path

import yaml

RUNS, NOISE, STEER_DEG = 300, 0.02, 2.0


def _run(argv: list[str]) -> str:
    """Run `uqdrive ARGV`; a console block with the command and everything it printed."""
    from uqdrive.cli.main import main

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err), warnings.catch_warnings():
        code = main(argv)
    if code != 0:
        raise RuntimeError(f"uqdrive {' '.join(argv)} failed: {err.getvalue()}")
    return "```console\n$ uqdrive " + " ".join(argv) + "\n" + (out.getvalue() + err.getvalue()).rstrip("\n") + "\n```\n"


def _refused(argv: list[str]) -> str:
    """Run `uqdrive ARGV`, which must refuse its input (exit status 2); the command and its line."""
    from uqdrive.cli.main import main

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err), warnings.catch_warnings():
        code = main(argv)
    if code != 2:
        raise RuntimeError(f"uqdrive {' '.join(argv)} was not refused (exit status {code})")
    return "$ uqdrive " + " ".join(argv) + "\n" + (out.getvalue() + err.getvalue()).rstrip("\n")


#: Vehicle files with one mistake each, made from the packaged sedan: file name -> (what is wrong, change).
MISTAKES = {
    "bad_lf.yaml": ("the centre of gravity behind the rear axle", {"cg_to_front_axle": 2.9}),
    "kn_per_rad.yaml": ("cornering stiffness typed in kN/rad", {"cornering_stiffness": {"front": 160.0, "rear": 160.0}}),
    "negative_mass.yaml": ("a negative mass", {"mass": -1573.0}),
    "no_stiffness.yaml": ("no cornering stiffness", {"cornering_stiffness": None}),
}


def _errors(root: Path) -> str:
    """A console block of refusals: an unknown car and each file of :data:`MISTAKES`."""
    sedan = yaml.safe_load((root / "src" / "uqdrive" / "vehicles" / "rajamani_sedan.yaml").read_text())
    lines = [_refused(["identify", "sedan.nc", "--vehicle", "mustang", "--config", "mycar.yaml", "--out", "x"])]
    for name, (_, change) in MISTAKES.items():
        car = {k: v for k, v in {**sedan, **change}.items() if v is not None}
        Path(name).write_text(yaml.safe_dump(car, sort_keys=False))
        lines.append(_refused(["identify", "sedan.nc", "--vehicle", name, "--config", "mycar.yaml", "--out", "x"]))
    wrong = ", ".join(f"`{name}`: {what}" for name, (what, _) in MISTAKES.items())
    return (f"The packaged sedan's file with one mistake each ({wrong}), and a car that is not packaged:\n\n"
            "```console\n" + "\n".join(lines) + "\n```\n")


def write_example(root: Path, target: Path) -> None:
    """Simulate the sedan, identify it twice, and write the example's Markdown to ``target``; the
    refusals of mistaken vehicle files to ``target``'s name with ``_errors`` appended."""
    import xarray as xr

    config = yaml.safe_load((root / "config" / "test.yaml").read_text())
    config["steering"]["delta_max_deg"] = STEER_DEG
    cwd = os.getcwd()
    with tempfile.TemporaryDirectory() as tmp:
        os.chdir(tmp)
        try:
            Path("mycar.yaml").write_text(yaml.safe_dump(config, sort_keys=False))
            simulated = _run(["simulate", "--model", "nlst", "--vehicle", "rajamani_sedan", "--config", "mycar.yaml",
                              "--samples", str(RUNS), "--noise", f"{NOISE:g}", "--out", "sedan.nc"])
            with xr.open_dataset("sedan.nc") as ds:
                drawn = {k: (float(ds[k].mean()), float(ds[k].std(ddof=1))) for k in ("mu", "l_f") if k in ds}
            own = _run(["identify", "sedan.nc", "--vehicle", "rajamani_sedan", "--config", "mycar.yaml", "--out", "fit_sedan"])
            other = _run(["identify", "sedan.nc", "--vehicle", "bmw_320i", "--config", "mycar.yaml", "--out", "fit_bmw"])
            est = {k: json.loads(Path(f"{k}/estimate.json").read_text()) for k in ("fit_sedan", "fit_bmw")}
            errors = _errors(root)
        finally:
            os.chdir(cwd)
    right, wrong = est["fit_sedan"], est["fit_bmw"]
    text = ["**1. An ensemble of the sedan, with noise:**\n", simulated]
    if drawn:
        text.append("The runs' own draws: " + "; ".join(f"{k} mean {m:.4g}, std {s:.4g}" for k, (m, s) in drawn.items()) + ".\n")
    text += [
        "**2. Identify with the sedan's own constants:**\n", own,
        f"mu N({right['mu'][0]:.4g}, {right['mu'][1]:.4g}), l_f N({right['l_f'][0]:.4g}, {right['l_f'][1]:.4g}) m; "
        f"misfit {right['goodness_of_fit']['ratio']:.3g} times the noise. The identification model is the linear LST "
        "and the data come from the non-linear model, whose tyres give less force than the linear slope at larger "
        "slip angles: mu is read slightly low, and the misfit test may say so.\n",
        "**3. The same data with another car's constants (the BMW 320i):**\n", other,
        f"The optimiser compensates the other car's stiffnesses and inertia with mu N({wrong['mu'][0]:.4g}, "
        f"{wrong['mu'][1]:.4g}), and the misfit (`cost` in estimate.json) is {wrong['cost']:.4g} against "
        f"{right['cost']:.4g} with the right car: {wrong['cost'] / right['cost']:.3g} times as large. A misfit far above "
        "what the noise explains means that the vehicle constants do not fit the car: check the mass, yaw inertia "
        "and cornering stiffness (per axle, at mu = 1) before reading mu.\n",
    ]
    target.parent.mkdir(parents=True, exist_ok=True)
    for path, body in ((target, "\n".join(text)), (target.with_name(target.stem + "_errors.md"), errors)):
        if not path.exists() or path.read_text() != body:
            path.write_text(body, encoding="utf-8")

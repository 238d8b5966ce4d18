"""``uqdrive discover``: run the discrepancy workflow on any ensemble in the uqdrive schema and
write ``verdict.json``, ``model.yaml`` (the augmented model) and the figures.
"""

from __future__ import annotations

import json
import shutil
import tempfile
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

import numpy as np
import yaml

from ..inference.discrepancy import DEFAULT_CANDIDATES, DiscrepancyFinder, family_of
from ..io import MIN_RUNS, DataError, OutputError, check_run_count, read_ensemble, speed_profile
from ..outputs import raise_if_interrupted
from ..studies.manoeuvres import steering_command
from ..vehicle.effects import EFFECTS, expand_names
from ..vehicle_spec import OPTIONAL_QUANTITIES
from ..settings import Settings, Vehicle

__all__ = ["MIN_SAMPLES", "SEPARATING_INPUTS", "separating_inputs", "discover_file", "discover_dataset", "baseline_warnings", "write_outputs",
           "candidates_for_car"]

#: Fewer realisations give moment statistics too noisy for a verdict; the null band is bootstrapped
#: at the data's own run count, so it widens as the runs get fewer.
MIN_SAMPLES = MIN_RUNS

#: Manoeuvres (uqdrive.studies.manoeuvres) among which the verdict names the input that would
#: separate ambiguous candidates: slow and fast slaloms, steps, a chirp, a lane change.
SEPARATING_INPUTS = {
    "slalom_5deg_4s": ("slalom", {"amplitude_deg": 5.0, "period": 4.0}),
    "slalom_3deg_2s": ("slalom", {"amplitude_deg": 3.0, "period": 2.0}),
    "step_2deg": ("step", {"amplitude_deg": 2.0}),
    "step_5deg": ("step", {"amplitude_deg": 5.0}),
    "chirp_2deg": ("chirp", {"amplitude_deg": 2.0}),
    "lane_change_4deg": ("lane_change", {"amplitude_deg": 4.0}),
}


def separating_inputs(time) -> dict:
    """The commands of :data:`SEPARATING_INPUTS` on the measured time grid (rad)."""
    return {name: steering_command(m, time, params) for name, (m, params) in SEPARATING_INPUTS.items()}


def _checked_candidates(candidates: Sequence[str] | None):
    if candidates is None:
        return None
    if not list(candidates):
        raise DataError("--candidates names no candidate; give effect names or families separated by commas (e.g. "
                        "tyre_saturation,actuator_lag), or 'all'")
    try:
        return expand_names(candidates)
    except KeyError as err:
        raise DataError(str(err).strip("'\"") + "; give --candidates from those, separated by commas") from None


def candidates_for_car(names: Sequence[str], vehicle: Vehicle) -> tuple[list[str], list[dict]]:
    """The candidates ``names`` (registry names) whose required constants (``Effect.requires``) the
    car's settings ``vehicle`` give, and an ``untestable`` entry {"effect", "registry_name",
    "reason", "needs"} for each of the others: searching them would need a value the car lacks."""
    keep, untestable = [], []
    for name in names:
        missing = EFFECTS[name].missing(vehicle)
        if not missing:
            keep.append(name)
            continue
        what = " and ".join(f"{k} ({OPTIONAL_QUANTITIES[k][1]}, {OPTIONAL_QUANTITIES[k][0]})" for k in missing)
        untestable.append({"effect": family_of(name), "registry_name": name, "needs": list(missing),
                           "reason": f"{name}: the car gives no {what}; add {'them' if len(missing) > 1 else 'it'} "
                                     "to the vehicle file (or the config's vehicle section) to test this effect"})
    return keep, untestable


def discover_file(config: Mapping[str, Any], measured: Path, candidates: Sequence[str] | None, out: Path, posterior: bool | None = None,
                  log: Callable[[str], None] | None = None, model: Path | None = None, figures: bool = True, jobs: int | str = 1,
                  device: str = "cpu") -> dict:
    """Discover what the model misses in ``measured``; write the outputs into ``out`` atomically.

    ``posterior``: sample the emcee posterior of the augmented model into ``verdict.json``
    (True), never (False), or as config ``discrepancy.posterior`` says (None). ``log`` receives
    a progress line per stage (the workflow's log file). ``model``: a ``model.yaml`` written by
    discover to start from (its effects refitted, further ones added on top). ``figures``: draw
    bands.png and localisation.png too (False: verdict.json and model.yaml only). ``jobs``: worker
    processes for the fits of each search step, ``device`` who integrates the non-linear models
    (:class:`~uqdrive.inference.discrepancy.DiscrepancyFinder`).

    The whole folder is written beside ``out`` and renamed onto it only when everything
    succeeded, so a failure leaves no verdict behind. The data's speed (``v``, else the attribute
    ``v_c``: :func:`uqdrive.io.data_speed`) replaces the config's ``vehicle.speed_kmh`` where they differ.

    The file may carry any non-empty set of channels (psi, psi_dot, beta, y, a_y) and a speed
    ``v`` that changes over time: the baseline, the null band and every candidate are computed
    on exactly those channels along that speed; ``verdict.json``'s ``untestable`` names the
    candidates the channels cannot test (``lateral_kinematics`` without y).
    """
    finder, verdict = discover_dataset(config, read_ensemble(measured), str(measured), candidates, posterior, log, model, jobs, device)
    write_outputs(finder, verdict, out, figures)
    return verdict


def discover_dataset(config: Mapping[str, Any], ds, measured: str, candidates: Sequence[str] | None = None, posterior: bool | None = None,
                     log: Callable[[str], None] | None = None, model: Path | None = None, jobs: int | str = 1,
                     device: str = "cpu") -> tuple[DiscrepancyFinder, dict]:
    """:func:`discover_file` on the validated ensemble ``ds`` (named ``measured`` in messages and
    in the verdict), writing nothing: the fitted finder and the verdict.json fields.
    ``model_fits`` says whether the final model leaves no unexplained gap (no ``unrecognised``)."""
    names = _checked_candidates(candidates)
    start = _start_model(model, config) if model is not None else None
    check_run_count(ds.sizes["sample"], str(measured), "discover")
    if abs(float(ds["time"].values[0])) > 1e-9:
        raise DataError(f"{measured}: time must start at 0 s (the model starts at rest); it starts at {float(ds['time'].values[0])} s")
    profile = speed_profile(ds)
    if "v_c" not in ds.attrs:  # a 'v' that never changes is the constant speed; a profile's mean stands for it
        ds.attrs["v_c"] = float(np.ravel(ds["v"].values)[0]) if profile is None else float(np.mean(profile))
    v_c, kmh = float(ds.attrs["v_c"]), float(config["vehicle"]["speed_kmh"])
    # the data's speed wins, as in identify (the CLI says so)
    settings = Settings.from_config(config, speed=v_c if abs(v_c * 3.6 - kmh) > 1e-9 * kmh else None)
    requested = names if names is not None else expand_names(settings.discover.candidates or DEFAULT_CANDIDATES)
    names, lacking = candidates_for_car(requested, settings.vehicle)
    if not names:
        raise DataError(f"no candidate can be tested on this car: {'; '.join(u['reason'] for u in lacking)}")
    finder = DiscrepancyFinder(settings, candidates=names, posterior=posterior, inputs=separating_inputs(ds["time"].values), log=log, start_model=start, jobs=jobs,
                               device=device)
    if "beta" in ds and int(np.sum(~np.any(np.abs(ds["beta"].values) > settings.spin.threshold, axis=-1))) < MIN_SAMPLES:
        raise DataError(f"{measured}: fewer than {MIN_SAMPLES} realisations kept control (|beta| <= spin_threshold)")
    finder.fit(ds)
    verdict = dict(finder.verdict_, measured=str(measured), warnings=baseline_warnings(finder),
                   fixed=settings.uncertainty.known())
    verdict["untestable"] = lacking + list(verdict.get("untestable", []))
    verdict["model_fits"] = not any(e["effect"] == "unrecognised" for e in verdict["effects"])
    return finder, verdict


def _start_model(path: Path, config: Mapping[str, Any]) -> dict:
    """The effects and distributions of a ``model.yaml`` to start from (a DataError otherwise)."""
    from .model import load_model

    structure, dist = load_model(path, config)
    return {"effects": {name: dict(p) for name, p in structure.effects}, "distributions": dist}


def baseline_warnings(finder: DiscrepancyFinder) -> list[str]:
    """Warnings of the baseline fit, in the words of ``uqdrive identify``: the optimiser did not
    converge, or a distribution parameter (a std at zero excepted) sits at a bound of its search
    box. (Whether the baseline fits the data at all is the verdict's question.)"""
    from ..inference.discrepancy.fit import THETA_BOUNDS
    from ..vehicle.augmented import THETA_NAMES
    from .identify import fit_warnings

    base = finder.baseline_
    layout = finder.settings.layout
    theta0 = list(layout.start)
    free = [i for i in range(len(THETA_NAMES)) if i not in layout.known]
    pick = lambda seq: [seq[i] for i in free]  # noqa: E731
    out = fit_warnings(pick(base.theta_), pick(theta0), pick(THETA_BOUNDS), pick(THETA_NAMES), bool(base.success_), base.message_)
    return [f"baseline fit: {w}" for w in out]


def _draw_figures(finder: DiscrepancyFinder, verdict: dict, folder: Path) -> None:
    """bands.png and localisation.png into ``folder`` (matplotlib is imported here: a run
    without figures does not load it)."""
    from ..plots.discrepancy import bands_before_after, localisation_map
    from ..plots.figure import save_figure

    save_figure(bands_before_after(finder.time_, finder.measured_, finder.baseline_.statistics_, finder.augmented_.statistics_, verdict["effect"],
                                   channels=finder.channels_), folder / "bands.png")
    save_figure(localisation_map(finder.time_, finder.baseline_.z_, finder.band_.threshold, channels=finder.channels_), folder / "localisation.png")


def write_outputs(finder: DiscrepancyFinder, verdict: dict, out: Path, figures: bool = True) -> None:
    """verdict.json, model.yaml, bands.png and localisation.png (without ``figures``: the first two)
    into ``out`` (all or nothing; missing parent folders are created, and removed again when the
    writing fails)."""
    out = Path(out)
    parent = out.parent if str(out.parent) else Path(".")
    created = [p for p in (parent, *parent.parents) if not p.exists()]
    parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.", dir=parent))
    try:
        (tmp / "verdict.json").write_text(json.dumps(verdict, indent=2) + "\n")
        (tmp / "model.yaml").write_text(yaml.safe_dump(finder.model_document(), sort_keys=False))
        if figures:
            _draw_figures(finder, verdict, tmp)
        raise_if_interrupted()
        if out.exists() and not out.is_dir():
            raise OutputError(f"output folder '{out}' became a regular file meanwhile; it is not replaced by a folder: choose another --out")
        if out.exists():
            old = Path(tempfile.mkdtemp(prefix=f".{out.name}.old.", dir=parent))
            out.rename(old / out.name)
            tmp.rename(out)
            shutil.rmtree(old, ignore_errors=True)
        else:
            tmp.rename(out)
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)
        for folder in created if not out.exists() else ():
            try:
                folder.rmdir()
            except OSError:
                pass  # someone else put files there meanwhile: leave it

"""The Python API of uqdrive's commands: ``identify``, ``discover`` and ``simulate`` on a file or an
xarray.Dataset, returning results that hold what the command line writes, draws and prints.

The command line is a thin layer over these functions: its files are the results' ``to_dict()``
and ``plot()``, its summary line their ``summary()``.
"""

from __future__ import annotations

import copy
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

import xarray as xr

from ..config import ConfigError, load_config, validate_config
from ..io import read_ensemble, validate_ensemble
from ..settings import Settings

__all__ = ["Estimate", "Verdict", "identify", "discover", "simulate", "resolve_config", "car_record", "car_warnings"]

#: The settings of :func:`identify` (the flags of ``uqdrive identify``) and their defaults.
IDENTIFY_SETTINGS = {"cost": "std", "m_load": None, "starts": 0, "state_scale": "rms_mean"}
#: The settings of :func:`discover` (the flags of ``uqdrive discover``) and their defaults.
DISCOVER_SETTINGS = {"posterior": None, "jobs": 1, "device": "cpu"}


def resolve_config(config: str | Path | Mapping[str, Any] | None = None, vehicle: str | Path | None = None) -> dict:
    """The validated config: ``config`` a file, a mapping (a loaded config) or None (the packaged
    default), with the car of ``vehicle`` (a packaged vehicle name or a vehicle file) if given."""
    if config is None or isinstance(config, (str, Path)):
        return load_config(config, vehicle=vehicle)
    if vehicle is None:
        return dict(config)
    return validate_config({**copy.deepcopy(dict(config)), "vehicle_file": str(vehicle)})


#: The vehicle constants recorded with every output (the config's names) and their words and units.
CAR_KEYS = {"m_base": "mass (kg)", "J0": "yaw inertia over mass J0 (m^2)", "wheelbase": "wheelbase (m)",
            "c_Sf": "front cornering stiffness c_Sf (-)", "c_Sr": "rear cornering stiffness c_Sr (-)"}


def car_record(config: Mapping[str, Any]) -> dict:
    """The car of ``config`` as every output records it: its name and main constants."""
    vehicle = config["vehicle"]
    return {"name": str(vehicle.get("name", "the config's car")), **{k: float(vehicle[k]) for k in CAR_KEYS}}


def car_warnings(ds: xr.Dataset, config: Mapping[str, Any]) -> list[str]:
    """A warning when the ensemble records the car that made it (attribute ``vehicle``) and that
    car's constants differ from the car it is now fitted with."""
    try:
        made = json.loads(ds.attrs["vehicle"])
        differ = [k for k in CAR_KEYS if abs(float(made[k]) - float(config["vehicle"][k])) > 1e-9 * abs(float(made[k]))]
    except (KeyError, TypeError, ValueError):  # no record, or not one of uqdrive's
        return []
    if not differ:
        return []
    given = car_record(config)
    detail = ", ".join(f"{CAR_KEYS[k]} {made[k]:.6g} there, {given[k]:.6g} here" for k in differ)
    return [f"the data record the car '{made.get('name', '?')}' and are fitted with '{given['name']}', whose constants differ "
            f"({detail}): if the data's car is the right one, pass it with --vehicle (vehicle= in Python)"]


def _settings(given: Mapping[str, Any], defaults: Mapping[str, Any], command: str) -> dict:
    unknown = sorted(set(given) - set(defaults))
    if unknown:
        raise TypeError(f"{command}() got unknown setting(s) {', '.join(unknown)}; known: {', '.join(defaults)}")
    return {**defaults, **given}


def _dataset(data: str | Path | xr.Dataset) -> tuple[xr.Dataset, str]:
    """The validated ensemble of ``data`` (a file or a Dataset) and the name messages give it."""
    if isinstance(data, xr.Dataset):
        return validate_ensemble(data.copy(), "dataset"), "dataset"
    return read_ensemble(data), str(data)


def _json(document: Mapping[str, Any]) -> dict:
    """The document as its JSON file holds it (tuples as lists, keys as strings)."""
    return json.loads(json.dumps(document, allow_nan=False))


@dataclass(eq=False)
class Estimate:
    """The identified distributions of an ensemble (what ``uqdrive identify`` writes).

    Attributes
    ----------
    mu, l_f : tuple of float
        Mean and std of the friction coefficient (-) and of the front axle distance l_f (m).
    F_w_mean : tuple of float
        Low and high end (N) of the uniform mean side wind.
    converged : bool
        The optimiser converged, the model fits and no warning was raised.
    optimiser_converged, model_fits : bool, bool or None
        The optimiser's own verdict; the misfit test (None where it could not be made).
    warnings, notes : list of str
        Why the fit is not to be trusted, each with its fix; facts about a sound fit.
    """

    document: dict
    _draw: Callable = field(repr=False)

    def __getattr__(self, name: str):
        if name.startswith("_") or name not in self.__dict__.get("document", {}):
            raise AttributeError(name)
        value = self.document[name]
        return tuple(value) if name in ("mu", "l_f", "F_w_mean") else value

    def to_dict(self) -> dict:
        """Exactly what estimate.json holds."""
        return _json(self.document)

    def plot(self):
        """fit.png as a matplotlib Figure: measured mean +- 2 std per channel against the model's."""
        return self._draw(None)

    def summary(self, out: str | Path | None = None) -> str:
        """The line ``uqdrive identify`` prints (naming ``out/estimate.json`` when ``out`` is given)."""
        from .identify import fit_status

        d = self.document
        head = "converged" if d["converged"] else "NOT CONVERGED, see the warnings"
        fmt = lambda v, n: tuple(None if x is None else round(x, n) for x in v)  # noqa: E731
        where = f"wrote {Path(out) / 'estimate.json'}: " if out is not None else ""
        with_ = f" with {sorted(d['effects'])}" if "effects" in d else ""
        return (f"{where}mu N{fmt(d['mu'], 4)}, l_f N{fmt(d['l_f'], 4)}, F_w_mean U{fmt(d['F_w_mean'], 1)}{with_} "
                f"({head}: {fit_status(d)}; {d['iterations']} iterations, {d['n_spun']} lost control)")

    def save(self, out: str | Path, overwrite: bool = True) -> None:
        """Write estimate.json and fit.png into the folder ``out`` (all or nothing)."""
        from .identify import write_outputs

        write_outputs(Path(out), self.to_dict(), self._draw, overwrite)


@dataclass(eq=False)
class Verdict:
    """What an ensemble's model misses, named (what ``uqdrive discover`` writes).

    Attributes
    ----------
    effect : str
        The first named effect, ``none`` or ``unrecognised``.
    effects : list of dict
        Every named effect with its parameters, intervals and the gap after it.
    gap_before, gap_after : float
        The excess misfit of the baseline and of the final model (0: none beyond sampling).
    model_fits : bool
        The final model leaves no unexplained gap.
    untestable : list of dict
        The candidates not searched, each with the reason: ``{"effect", "registry_name", "reason"}``,
        plus ``"needs"`` (the car's missing constants, e.g. ``["cg_height"]``) for one the car
        cannot test; the others act only on channels the data lack.
    finder : uqdrive.inference.discrepancy.DiscrepancyFinder
        The fitted finder (bands, fits, the augmented model document).
    """

    document: dict
    finder: Any = field(repr=False)

    def __getattr__(self, name: str):
        if name.startswith("_") or name not in self.__dict__.get("document", {}):
            raise AttributeError(name)
        return self.document[name]

    def to_dict(self) -> dict:
        """Exactly what verdict.json holds."""
        return _json(self.document)

    def model_document(self) -> dict:
        """Exactly what model.yaml holds: the baseline with the named effects and distributions."""
        return self.finder.model_document()

    def plot(self, kind: str = "bands"):
        """bands.png (``kind="bands"``: the measured statistics against the null band before and
        after) or localisation.png (``"localisation"``) as a matplotlib Figure."""
        from ..plots.discrepancy import bands_before_after, localisation_map

        f = self.finder
        if kind == "bands":
            return bands_before_after(f.time_, f.measured_, f.baseline_.statistics_, f.augmented_.statistics_, self.document["effect"],
                                      channels=f.channels_)
        if kind == "localisation":
            return localisation_map(f.time_, f.baseline_.z_, f.band_.threshold, channels=f.channels_)
        raise ValueError(f"kind must be 'bands' or 'localisation', not {kind!r}")

    def summary(self, out: str | Path | None = None) -> str:
        """The line ``uqdrive discover`` prints (naming ``out/verdict.json`` when ``out`` is given), with
        the candidates the car or the channels could not test and what each needs."""
        v = self.document
        named = ", ".join(e["effect"] for e in v["effects"]) or v["effect"]
        where = f"wrote {Path(out) / 'verdict.json'}: " if out is not None else ""
        from ..vehicle.effects import acts_on  # an entry without "needs" lacks the channels the effect acts on

        untested = [f"{u['registry_name']} (needs {', '.join(u.get('needs') or acts_on(u['registry_name']) or ())})" for u in v.get("untestable", [])]
        return (f"{where}effects {named}" + (f" (first ambiguous with {', '.join(v['ambiguous_with'])})" if v["ambiguous_with"] else "")
                + f", gap {v['gap_before']:.3g} -> {v['gap_after']:.3g} ({v['evidence']['n_spun']} lost control)"
                + (f"; untestable: {', '.join(untested)}" if untested else ""))

    def save(self, out: str | Path, figures: bool = True) -> None:
        """Write verdict.json, model.yaml, bands.png and localisation.png (without ``figures``: the
        first two) into ``out`` (all or nothing)."""
        from .discover import write_outputs

        write_outputs(self.finder, self.to_dict(), Path(out), figures)


def identify(data: str | Path | xr.Dataset, *, config=None, vehicle=None, model: str | Path | None = None,
             progress: Callable[[str], None] | None = None, **settings) -> Estimate:
    """Identify N(mu), N(l_f) and U(F_w_mean) from an ensemble, as ``uqdrive identify`` does.

    Parameters
    ----------
    data : path or xarray.Dataset
        An ensemble in the uqdrive data schema.
    config : path, mapping or None
        The config (None: the packaged default).
    vehicle : str or path, optional
        A packaged vehicle name or a vehicle file replacing the config's car.
    model : path, optional
        A model.yaml written by :func:`discover`: identify with its effects held at their values.
    progress : callable, optional
        Receives one line per stage (the command line prints them with the elapsed time).
    **settings
        ``cost`` (default ``"std"``), ``m_load`` (kg, default the config's), ``starts`` (default 0),
        ``state_scale`` (default ``"rms_mean"``): the flags of ``uqdrive identify``.

    Returns
    -------
    Estimate
    """
    s = _settings(settings, IDENTIFY_SETTINGS, "identify")
    say = progress or (lambda line: None)
    cfg = resolve_config(config, vehicle)
    say("reading the ensemble")
    ds, source = _dataset(data)
    if model is not None:
        from .model import identify_with_model

        say("fitting the augmented model")
        summary, draw = identify_with_model(cfg, ds if source == "dataset" else Path(source), Path(model), None)
        return Estimate(_with_car(summary, ds, cfg), draw)
    from .identify import identify_dataset

    say(f"fitting the chaos model (cost {s['cost']}, {s['starts']} extra starts)")
    summary, draw = identify_dataset(cfg, ds, source, s["cost"], s["m_load"], s["starts"], s["state_scale"])
    return Estimate(_with_car(summary, ds, cfg), draw)


def _with_car(document: dict, ds: xr.Dataset, config: Mapping[str, Any]) -> dict:
    """The document with the car it was fitted with and a warning if the data's car differs."""
    document["warnings"] = list(document.get("warnings", [])) + car_warnings(ds, config)
    document["vehicle"] = car_record(config)
    return document


def discover(data: str | Path | xr.Dataset, *, config=None, vehicle=None, candidates: Sequence[str] | None = None,
             model: str | Path | None = None, progress: Callable[[str], None] | None = None, **settings) -> Verdict:
    """Find and name what the model misses in an ensemble, as ``uqdrive discover`` does.

    Parameters
    ----------
    data : path or xarray.Dataset
        An ensemble in the uqdrive data schema.
    config, vehicle
        As for :func:`identify`.
    candidates : sequence of str, optional
        Candidate effects or families, ``"all"`` every registered one (default: the config's
        ``discrepancy.candidates``, ``all`` in the packaged config); an effect that needs a constant
        the car lacks is not searched but listed in ``untestable`` with the reason.
    model : path, optional
        A model.yaml of a previous discover to start from.
    progress : callable, optional
        Receives one line per stage.
    **settings
        ``posterior`` (True, False or None: as the config says); ``jobs``, worker processes for
        the fits of each search step (a count or ``"auto"``, the CPUs this process may use;
        default 1), the same verdict for every count; ``device`` who integrates the non-linear
        models, ``"cpu"`` (default), ``"gpu"`` (JAX, the same numbers to 1e-10; the fits in this
        process) or ``"auto"``, as :func:`simulate`'s.

    Returns
    -------
    Verdict
    """
    from ..numerics.backend import resolve_device
    from .discover import discover_dataset

    s = _settings(settings, DISCOVER_SETTINGS, "discover")
    resolve_device(s["device"])  # refused before any work
    cfg = resolve_config(config, vehicle)
    if progress is not None:
        progress("reading the ensemble")
    ds, source = _dataset(data)
    names = candidate_names(candidates)
    finder, verdict = discover_dataset(cfg, ds, source, names, s["posterior"], progress, None if model is None else Path(model), s["jobs"],
                                       s["device"])
    return Verdict(_with_car(verdict, ds, cfg), finder)


def candidate_names(candidates: str | Sequence[str] | None) -> list[str] | None:
    """The candidate list of :func:`discover`: None (the config's), names and families, where
    ``"all"`` stands for every registered effect."""
    if candidates is None:
        return None
    names = [candidates] if isinstance(candidates, str) else list(candidates)
    if "all" in names:
        from ..vehicle.effects import EFFECTS

        names = [n for n in names if n != "all"] + [n for n in EFFECTS if n not in names]
    return names


def simulate(model: str | Path = "lst", *, config=None, vehicle=None, steer: str = "normal", noise: float = 0.0,
             samples: int | None = None, seed: int | None = None, device: str = "cpu") -> xr.Dataset:
    """A Monte Carlo ensemble in the uqdrive data schema, as ``uqdrive simulate`` writes it.

    Parameters
    ----------
    model : {"lst", "nlst"} or path
        The linear or non-linear single-track model, or a model.yaml written by :func:`discover`.
    config, vehicle
        As for :func:`identify`.
    steer : {"normal", "inverted"}
        The slalom steering input or its inverted form.
    noise : float
        Measurement-noise intensity A in [0, 1] (0: clean).
    samples, seed : int, optional
        Realisations and root seed (default: the config's).
    device : {"cpu", "gpu", "auto"}
        Where the NLST (:func:`uqdrive.simulate_ensemble`) or a model.yaml's non-linear model is
        integrated: cpu the NumPy reference, gpu JAX on a GPU (``pip install "uqdrive[gpu]"``),
        auto the GPU when one is visible.

    Returns
    -------
    xarray.Dataset
    """
    import numpy as np

    from ..numerics.backend import resolve_device
    from ..rng import rng_stream
    from ..vehicle.montecarlo import simulate_ensemble
    from ..vehicle.noise import noisy_ensemble
    from ..vehicle.single_track import STATES

    backend = resolve_device(device)  # refused before any work
    cfg = resolve_config(config, vehicle)
    if str(model) not in ("lst", "nlst"):
        from .model import simulate_model

        n = int(cfg["montecarlo"]["samples"] if samples is None else samples)
        ds = simulate_model(cfg, Path(model), steer, n, int(cfg["seed"] if seed is None else seed), backend)
    else:
        ds = simulate_ensemble(Settings.from_config(cfg), str(model), steer, samples=samples, seed=seed, device=device)
    bad = [s for s in STATES if not np.all(np.isfinite(ds[s].values))]
    if bad:
        raise ConfigError(f"the simulation diverged ('{bad[0]}' not finite) with this config: vehicle.* and uncertainty.* "
                          "lie outside the model's stable range; give physical values")
    if noise > 0:
        ds = noisy_ensemble(ds, noise, rng_stream(ds.attrs["seed"], "noise", round(noise * 1e6)))
    ds.attrs["vehicle"] = json.dumps(car_record(cfg))
    return ds

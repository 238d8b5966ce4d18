"""Command line of uqdrive: ``simulate`` writes an ensemble in the data schema, ``identify`` fits
the parameter distributions to one, ``discover`` finds and names what the model misses in one,
``config`` writes out or checks a configuration, ``vehicles`` lists the packaged vehicle files.

Every refusal is one line on stderr naming the field and the fix, exit code 2, and nothing is
written; SIGINT/SIGTERM end a run cleanly (temporaries removed, exit 128 + signal number).
Adding a subcommand: one ``_add_<name>`` that builds its parser and one ``_<name>(args)``.
"""

from __future__ import annotations

import argparse
import signal
import sys
import threading
import warnings
from contextlib import contextmanager
from pathlib import Path

from .._version import __version__
from ..config import DEFAULT_CONFIG_NAME, ConfigError, default_config_text, load_config
from ..io import MIN_RUNS, DataError, OutputError, atomic_path, check_replaced_folder, check_writable
from ..interrupts import Interrupted, deliver, shielded, forget_signals, raise_if_interrupted, signal_received
from .help_text import CANDIDATES_TEXT, DEVICE_HELP, HelpFormatter, candidate_listing, epilog
from .import_runs import add_import
from .validation import SEED_MAX, OneLineParser, bounded_int, device_choice, finite_float, jobs_count, registry_choice, stderr_line
from ..settings import Settings

__all__ = ["main", "build_parser", "Interrupted"]

CONFIG_HELP = (f"YAML config (default: the packaged {DEFAULT_CONFIG_NAME}, identical to the repository's "
               "config/config.yaml; write it out to edit with 'uqdrive config --dump FILE')")
FORCE_HELP = "replace an existing output (atomically); without it an existing output is refused"
VEHICLE_HELP = ("the car: a packaged vehicle name ('uqdrive vehicles' lists them) or a vehicle file NAME.yaml; replaces the "
                "config's car (vehicle section but speed_kmh, g; l_f mean; tyre C, E when the file gives them)")
IDENTIFY_OUTPUTS = ("estimate.json", "fit.png")
DISCOVER_OUTPUTS = ("verdict.json", "model.yaml", "bands.png", "localisation.png")
#: Exit status of ``--strict`` when the model does not fit the data (identify: the misfit test
#: fails; discover: a gap no candidate explains remains), and when the optimiser did not converge.
EXIT_MODEL_DOES_NOT_FIT = 3
EXIT_NOT_CONVERGED = 4
STRICT_HELP = (f"exit with status {EXIT_MODEL_DOES_NOT_FIT} when the model does not fit the data{{}}, the outputs written "
               "all the same; without it such a result exits 0 with warnings")
QUIET_HELP = "print no progress (the stages and their elapsed time, on stderr when it is a terminal)"
STATUS_TEXT = (f"exit status: 0 done; 2 refused input; with --strict {EXIT_MODEL_DOES_NOT_FIT} when the model does not fit "
               f"the data\n(outputs written), {EXIT_NOT_CONVERGED} when the optimiser did not converge (identify)")


def _speed_said(config, ds) -> str | None:
    """The note when the data's speed (its v, else its v_c: :func:`uqdrive.io.data_speed`) replaced
    the config's vehicle.speed_kmh or a v_c beside v was ignored; None when there is nothing to say."""
    from ..io import data_speed

    v_c, ignored = data_speed(ds)
    name = "v" if "v" in ds else "v_c"
    kmh = float(config["vehicle"]["speed_kmh"])
    said = [ignored] if ignored else []
    if v_c is not None and abs(v_c * 3.6 - kmh) > 1e-9 * kmh:
        said.insert(0, f"the data's speed {name} = {v_c:.6g} m/s ({v_c * 3.6:.6g} km/h) replaces the config's vehicle.speed_kmh = {kmh:g} km/h")
    return f"uqdrive: note: {'; '.join(said)}" if said else None


def _car_said(args, config, ds) -> str | None:
    """The note when neither --vehicle nor --config named a car and the data do not record theirs:
    the packaged car is then used, which is rarely the user's."""
    if args.vehicle is not None or args.config is not None or "vehicle" in ds.attrs:
        return None
    v = config["vehicle"]
    return (f"uqdrive: note: no --vehicle given: fitted with the packaged config's car (mass {v['m_base']:g} kg, wheelbase "
            f"{v['wheelbase']:g} m); give your car with --vehicle NAME|FILE ('uqdrive vehicles' lists the packaged ones)")


def _notes(config, measured: Path, args=None) -> None:
    """The data's notes once the command succeeded (a refusal stays one line: the reader names
    what is wrong), from one read of the file's header: the speed, then (with ``args``) the car."""
    try:
        import xarray as xr

        with shielded(), xr.open_dataset(measured) as ds:
            said = [_speed_said(config, ds), None if args is None else _car_said(args, config, ds)]
    except Exception:  # noqa: BLE001 - the reader of the command reports what is wrong
        return
    for line in filter(None, said):
        stderr_line(line)


def _speed_notice(config, measured: Path) -> None:
    """The speed's note alone (:func:`_notes` without the car)."""
    _notes(config, measured)


# -- subcommands --------------------------------------------------------------------------------
def _add_simulate(sub) -> None:
    p = sub.add_parser("simulate", help="simulate a Monte Carlo ensemble of the single-track model into a netCDF file",
                       description="Simulate a Monte Carlo ensemble of the single-track model with the config's distributions "
                                   "under a slalom steering input and write it in the uqdrive data schema.",
                       formatter_class=HelpFormatter, epilog=epilog("simulate"))
    p.add_argument("--model", required=True, type=_model_choice, metavar="{lst,nlst,MODEL.yaml}",
                   help="lst: the linear single-track model (linear tyre), nlst: the non-linear one (Magic-Formula tyre), "
                        "or the augmented model.yaml that "
                        "'uqdrive discover' wrote (the LST plus the named effect with its fitted parameters)")
    p.add_argument("--steer", default="normal", choices=("normal", "inverted"), help="steering input: normal, the config's sine slalom (steering.delta_max_deg, steering.period), or inverted, "
                        "the same slalom steered the other way first (default normal)")
    p.add_argument("--noise", type=finite_float("--noise", 0.0, 1.0), default=0.0, metavar="A",
                   help="measurement-noise intensity A, a finite number in [0, 1]: white Gaussian noise of std A times "
                        "each run's largest |value| added to every state (default 0: clean)")
    p.add_argument("--samples", type=bounded_int("--samples", 2, 10**7, "realisations"), default=None, metavar="N",
                   help="realisations, 2..10^7 (default: config montecarlo.samples)")
    p.add_argument("--seed", type=bounded_int("--seed", 0, SEED_MAX), default=None, metavar="S",
                   help=f"root seed of every random stream, 0..{SEED_MAX} (default: config seed)")
    p.add_argument("--device", default="cpu", type=device_choice, choices=("auto", "cpu", "gpu"), help=DEVICE_HELP.format(
        what="the NLST or a model.yaml's non-linear model is", cpu="the NumPy reference, the same bits on every machine", gpu="",
        tail=". The LST always runs on the CPU"))
    p.add_argument("--config", type=Path, default=None, metavar="FILE", help=CONFIG_HELP)
    p.add_argument("--vehicle", default=None, metavar="NAME|FILE", help=VEHICLE_HELP)
    p.add_argument("--out", type=Path, required=True, metavar="FILE.nc", help="output netCDF file (its folder must exist)")
    p.add_argument("--force", action="store_true", help=FORCE_HELP)
    p.set_defaults(run=_simulate)


def _simulate(args) -> None:
    from ..io import write_dataset
    from .api import resolve_config, simulate

    config = resolve_config(args.config, args.vehicle)
    check_writable(args.out, overwrite=args.force)
    ds = simulate(args.model, config=config, steer=args.steer, noise=args.noise, samples=args.samples, seed=args.seed, device=args.device)
    write_dataset(ds, args.out, overwrite=args.force)
    print(f"wrote {args.out}: {args.model.upper()}, {args.steer} steering, {ds.sizes['sample']} samples, "
          f"{ds.attrs['n_spun']} spun, noise A = {args.noise:g}")


def _add_identify(sub) -> None:
    p = sub.add_parser("identify", help="identify the distributions of mu, l_f and the mean wind from an ensemble",
                       formatter_class=HelpFormatter, epilog=epilog("identify", STATUS_TEXT),
                       description="Fit N(mu), N(l_f) and U(F_w_mean) of the linear single-track model's polynomial chaos "
                                   f"expansion to the mean and std of an ensemble of at least {MIN_RUNS} runs "
                                   "in the uqdrive data schema; write estimate.json and fit.png. Realisations that lost "
                                   "control (|beta| > config montecarlo.spin_threshold) are found from the data and handled by "
                                   "montecarlo.spin_policy.")
    p.add_argument("measured", type=Path, metavar="MEASURED.nc",
                   help=f"ensemble in the uqdrive data schema (simulated or measured), at least {MIN_RUNS} runs")
    p.add_argument("--cost", default="std", type=registry_choice("--cost", "uqdrive.inference.identify", "COSTS"), metavar="NAME",
                   help="time weights of the least-squares cost of mean and std, a name of uqdrive.inference.identify.COSTS: "
                        "std (uniform), inp (weighted by the steering input's magnitude) or dst (by the divergence of the "
                        "non-linear from the linear model; needs the config's slalom) (default std)")
    p.add_argument("--m-load", type=finite_float("--m-load", 0.0, 1e5, "kg"), default=None, metavar="KG",
                   help="assumed load mass in kg, finite, 0..1e5 (default: config uncertainty.m_load.mean)")
    p.add_argument("--starts", type=bounded_int("--starts", 0, 1000), default=0, metavar="N",
                   help="extra starting points of a global stage, 0..1000 (default 0: one local fit from the config's values)")
    p.add_argument("--state-scale", default="rms_mean", type=registry_choice("--state-scale", "uqdrive.inference.identify", "STATE_SCALES"),
                   metavar="NAME",
                   help="per-state residual scale of the cost. Default rms_mean: each state's residuals divided by the RMS of its "
                        "measured mean, unit-free and accurate on outside data; none: SI units as the thesis prints its cost, the "
                        "thesis-faithful setting the workflow's experiments use (config identification.state_scale); rms_std: by "
                        "the RMS of the measured std")
    p.add_argument("--model", type=Path, default=None, metavar="MODEL.yaml",
                   help="identify with the augmented model that 'uqdrive discover' wrote (its effects held at their fitted "
                        "values, distributions fitted on common random numbers) instead of the linear model's chaos expansion")
    p.add_argument("--config", type=Path, default=None, metavar="FILE", help=CONFIG_HELP)
    p.add_argument("--vehicle", default=None, metavar="NAME|FILE", help=VEHICLE_HELP)
    p.add_argument("--out", type=Path, required=True, metavar="DIR",
                   help="output folder for estimate.json and fit.png (created only once the input is accepted)")
    p.add_argument("--force", action="store_true", help=FORCE_HELP)
    p.add_argument("--strict", action="store_true",
                   help=STRICT_HELP.format(" (the misfit test fails)") + f"; and {EXIT_NOT_CONVERGED} when the optimiser did not converge")
    p.add_argument("--quiet", action="store_true", help=QUIET_HELP)
    p.set_defaults(run=_identify)


def _identify(args) -> int:
    from ..io import check_output_folder
    from .api import identify, resolve_config
    from .progress import Progress

    progress = Progress(quiet=args.quiet)
    config = resolve_config(args.config, args.vehicle)
    check_output_folder(args.out, IDENTIFY_OUTPUTS, overwrite=args.force)
    settings = {} if args.model is not None else {"cost": args.cost, "m_load": args.m_load, "starts": args.starts,
                                                  "state_scale": args.state_scale}
    estimate = identify(args.measured, config=config, model=args.model, progress=progress, **settings)
    progress("writing estimate.json and fit.png")
    estimate.save(args.out, overwrite=args.force)
    progress("done")
    _notes(config, args.measured, args)
    print(estimate.summary(args.out))
    _report_warnings(estimate.document)
    if args.strict and estimate.model_fits is False:
        return EXIT_MODEL_DOES_NOT_FIT
    if args.strict and not estimate.optimiser_converged:
        return EXIT_NOT_CONVERGED
    return 0


def _report_warnings(summary) -> None:
    """Every warning of a fit on stderr (through the warnings main() prints), every note on stdout."""
    for note in summary.get("notes", []):
        print(f"note: {note}")
    for message in summary.get("warnings", []):
        warnings.warn(message, UserWarning, stacklevel=2)


def _add_config(sub) -> None:
    p = sub.add_parser("config", help="write out the default config for editing, or check a config file",
                       formatter_class=HelpFormatter, epilog=epilog("config"),
                       description="Write the packaged default configuration (with its comments) to a file or stdout, "
                                   "or validate a configuration file.")
    what = p.add_mutually_exclusive_group(required=True)
    what.add_argument("--dump", metavar="FILE", help="write the default config to FILE ('-': stdout)")
    what.add_argument("--check", type=Path, metavar="FILE", help="validate FILE; print 'ok' or the first problem")
    p.add_argument("--force", action="store_true", help=FORCE_HELP + " (with --dump)")
    p.set_defaults(run=_config)


def _config(args) -> None:
    if args.check is not None:
        load_config(args.check)
        print(f"{args.check}: ok")
    elif args.dump == "-":
        sys.stdout.write(default_config_text())
    else:
        with atomic_path(args.dump, overwrite=args.force) as tmp:
            tmp.write_text(default_config_text(), encoding="utf-8")
        print(f"wrote {args.dump}: the default config; edit it and pass it with --config")


def _model_choice(value: str) -> str:
    if value in ("lst", "nlst") or value.endswith((".yaml", ".yml")):
        return value
    raise argparse.ArgumentTypeError(f"--model '{value}' is neither lst, nlst nor a model file; give lst, nlst or the model.yaml "
                                     "that uqdrive discover wrote (ending in .yaml)")


_model_choice.__name__ = "--model"


def _add_discover(sub) -> None:
    p = sub.add_parser("discover", help="find what the model misses in an ensemble, name the effect, add it, show the gap shrink",
                       formatter_class=HelpFormatter,
                       epilog=epilog("discover", CANDIDATES_TEXT + candidate_listing() + "\n\n" + STATUS_TEXT),
                       description="Fit the complete stochastic LST to an ensemble in the uqdrive data schema, calibrate a null "
                                   "band by parametric bootstrap, localise where the data leave it, name the missing physical "
                                   "effect among the candidates (or 'none' / 'unrecognised'), re-identify with it and write "
                                   "verdict.json, model.yaml, bands.png and localisation.png into --out.")
    p.add_argument("measured", type=Path, metavar="MEASURED.nc", help=f"ensemble in the uqdrive data schema, at least {MIN_RUNS} runs (that kept control)")
    p.add_argument("--candidates", default=None, metavar="a,b,...",
                   help="comma-separated candidate effects or families (default: config discrepancy.candidates, 'all' in "
                        "the packaged config); every registered effect is listed below, a family (sensor_bias, sensor_scale) "
                        "names one per channel, 'all' every registered effect")
    p.add_argument("--config", type=Path, default=None, metavar="FILE", help=CONFIG_HELP)
    p.add_argument("--vehicle", default=None, metavar="NAME|FILE", help=VEHICLE_HELP)
    p.add_argument("--out", type=Path, required=True, metavar="DIR",
                   help="output folder (written whole, only once the run succeeded; missing parent folders are created then)")
    p.add_argument("--posterior", action=argparse.BooleanOptionalAction, default=None,
                   help="sample the emcee posterior of the repaired model into verdict.json (--posterior) or never "
                        "(--no-posterior); default: as config discrepancy.posterior says (enabled, for the effects listed)")
    p.add_argument("--model", type=Path, default=None, metavar="DIR/model.yaml",
                   help="start from the augmented model a previous 'uqdrive discover' wrote: its effects are refitted with the "
                        "distributions and further effects added on top")
    p.add_argument("--figures", action=argparse.BooleanOptionalAction, default=True,
                   help="draw bands.png and localisation.png (default); --no-figures writes verdict.json and model.yaml "
                        "only (a batch of recordings: matplotlib is never loaded)")
    p.add_argument("--jobs", type=jobs_count, default=1, metavar="N|auto",
                   help="worker processes for the fits of each search step and the posterior's model evaluations (a step's "
                        "single fit, and its last fits on the cores of idle workers: their simulations in halves on two processes) "
                        "(default 1; 'auto': every CPU this process may use); "
                        "the verdict is the same for every N")
    p.add_argument("--device", default="cpu", type=device_choice, choices=("auto", "cpu", "gpu"), help=DEVICE_HELP.format(
        what="the non-linear models are", cpu="the compiled CPU path", gpu="; the fits then run in one process, --jobs 1", tail=""))
    p.add_argument("--force", action="store_true", help=FORCE_HELP)
    p.add_argument("--strict", action="store_true", help=STRICT_HELP.format(" (a gap that no candidate explains remains)"))
    p.add_argument("--quiet", action="store_true", help=QUIET_HELP)
    p.set_defaults(run=_discover)


def _discover(args) -> int:
    from .api import discover, resolve_config
    from .progress import Progress

    progress = Progress(quiet=args.quiet)
    config = resolve_config(args.config, args.vehicle)
    out = check_replaced_folder(args.out, overwrite=args.force, names=DISCOVER_OUTPUTS)
    candidates = None if args.candidates is None else [c.strip() for c in args.candidates.split(",") if c.strip()]
    verdict = discover(args.measured, config=config, candidates=candidates, model=args.model, progress=progress,
                       posterior=args.posterior, jobs=args.jobs, device=args.device)
    progress("writing verdict.json, model.yaml" + (" and the figures" if args.figures else ""))
    verdict.save(out, figures=args.figures)
    progress("done")
    _notes(config, args.measured, args)
    print(verdict.summary(out))
    _report_warnings(verdict.document)
    return EXIT_MODEL_DOES_NOT_FIT if args.strict and not verdict.model_fits else 0


def _add_vehicles(sub) -> None:
    p = sub.add_parser("vehicles", help="list the packaged vehicle files (or check given ones) with their main numbers",
                       formatter_class=HelpFormatter, epilog=epilog("vehicles"),
                       description="List the packaged vehicle files, or check the named ones or vehicle files, with their "
                                   "main numbers in engineering units and the model's internal constants derived from them "
                                   "(with the tyre C, E and g of --config where a file does not give them).")
    p.add_argument("vehicles", nargs="*", metavar="NAME|FILE", help="vehicle names or files (default: every packaged vehicle)")
    p.add_argument("--config", type=Path, default=None, metavar="FILE", help=CONFIG_HELP)
    p.set_defaults(run=_vehicles)


def _vehicles(args) -> None:
    from ..vehicle_spec import engineering_terms, vehicle_names

    rows = []
    for name in args.vehicles or vehicle_names():
        config = load_config(args.config, vehicle=name)
        e, v = engineering_terms(config), config["vehicle"]
        rows.append((v["name"], f"{e['mass']:.6g}", f"{e['yaw_inertia']:.6g}", f"{e['wheelbase']:.5g}", f"{e['l_f']:.5g}",
                     f"{e['cornering_stiffness_front'] / 1e3:.4g}", f"{e['cornering_stiffness_rear'] / 1e3:.4g}",
                     f"{e['C']:.5g}", f"{e['E']:.5g}", f"{v['J0']:.5g}", f"{v['c_Sf']:.5g}", f"{v['c_Sr']:.5g}",
                     _description(name)))
    head = ("vehicle", "mass kg", "I_z kg m^2", "L m", "l_f m", "C_af kN/rad", "C_ar kN/rad", "C", "E", "J0 m^2", "c_Sf", "c_Sr",
            "description")
    widths = [max(len(r[i]) for r in [head, *rows]) for i in range(len(head))]
    for row in [head, *rows]:
        print("  ".join(c.ljust(w) if i in (0, len(row) - 1) else c.rjust(w) for i, (c, w) in enumerate(zip(row, widths))).rstrip())


def _description(reference: str) -> str:
    from ..config import read_vehicle_file

    return read_vehicle_file(reference)[1]["description"]


SUBCOMMANDS = (_add_simulate, _add_identify, _add_discover, _add_config, _add_vehicles, add_import)


# -- parser and shared error handling -------------------------------------------------------------
def build_parser() -> OneLineParser:
    """The argument parser of the `uqdrive` command and its subcommands (one-line refusals, exit 2)."""
    parser = OneLineParser(prog="uqdrive", description="uqdrive: simulate single-track vehicle ensembles and identify the "
                                                        "distributions of their uncertain parameters from simulated or measured ones.",
                           epilog="Exit codes: 0 done, 2 refused input (one line on stderr: the field and the fix), "
                                  f"{EXIT_MODEL_DOES_NOT_FIT} the model does not fit and {EXIT_NOT_CONVERGED} the optimiser "
                                  "did not converge (identify and discover with --strict), "
                                  "128 + N interrupted by signal N. '%(prog)s COMMAND --help' describes each command.")
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for add in SUBCOMMANDS:
        add(sub)
    return parser


@contextmanager
def _signals_exit_cleanly():
    """Turn SIGINT/SIGTERM/SIGHUP into :class:`Interrupted` (later ones are ignored during cleanup),
    raised where that is safe (:func:`uqdrive.interrupts.deliver`: an import or a shielded block first ends)."""
    names = [s for s in ("SIGINT", "SIGTERM", "SIGHUP") if hasattr(signal, s)]
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    recheck = hasattr(signal, "setitimer")

    def handler(signum, frame):
        for name in names:
            signal.signal(getattr(signal, name), signal.SIG_IGN)
        signal_received(signum)  # outputs check it: code called back from C swallows the exception
        deliver(frame, recheck)

    unraisable = sys.unraisablehook

    def quiet(info):  # the swallowed Interrupted is raised again before any output (no traceback for it)
        if not isinstance(info.exc_value, Interrupted):
            unraisable(info)

    old = {name: signal.signal(getattr(signal, name), handler) for name in names}
    alarm = signal.signal(signal.SIGALRM, lambda _, frame: deliver(frame, recheck)) if recheck else None
    sys.unraisablehook = quiet
    try:
        yield
    finally:
        forget_signals()
        if recheck:
            signal.signal(signal.SIGALRM, alarm)
        for name, previous in old.items():
            signal.signal(getattr(signal, name), previous)
        sys.unraisablehook = unraisable


def main(argv: list[str] | None = None) -> int:
    """Run the `uqdrive` command line on ``argv`` (``sys.argv[1:]`` if None); return the exit status
    (0 done, 2 refused input, 128 + N interrupted by signal N)."""
    try:
        args = build_parser().parse_args(argv)
    except SystemExit as exc:  # --help (0) or a refused flag (2, one line already printed)
        return exc.code if isinstance(exc.code, int) else 2
    with _signals_exit_cleanly(), warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("default")
        try:
            try:
                status = args.run(args) or 0
            except Exception:
                # the signal's exception may surface as another: an extension module being
                # imported when it arrives reports ImportError (numba's, imported at first use)
                raise_if_interrupted()
                raise
            raise_if_interrupted()
            for message in dict.fromkeys(str(w.message) for w in caught):
                stderr_line(f"uqdrive: warning: {message}")
            return status
        except (ConfigError, DataError, OutputError) as exc:
            stderr_line(f"uqdrive: error: {exc}")
            return 2
        except MemoryError:
            stderr_line("uqdrive: error: out of memory; lower --samples or the config's time grid (time.t_end, time.dt)")
            return 2
        except (Interrupted, KeyboardInterrupt) as exc:
            signum = exc.signum if isinstance(exc, Interrupted) else signal.SIGINT
            stderr_line(f"uqdrive: interrupted by {signal.Signals(signum).name}; partial outputs and temporary files removed")
            return 128 + int(signum)
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())

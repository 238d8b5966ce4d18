"""The ``uqdrive import`` subcommand: recorded runs (MDF4, CSV or MATLAB, one file each) into one ensemble
of the data schema, with a line per run giving its offset and steering deviation.
"""

from __future__ import annotations

import json
from pathlib import Path

from .validation import finite_float

__all__ = ["add_import", "run_import"]

FORCE_HELP = "replace an existing output (atomically); without it an existing output is refused"


def add_import(sub) -> None:
    """Add the ``import`` subcommand to the subparsers ``sub``."""
    p = sub.add_parser("import", help="import recorded runs (MDF4, CSV or MATLAB logs, one per run) into an ensemble netCDF file",
                       description="Read one recording per run (ASAM MDF4 .mf4/.mdf through asammdf, CSV with a header of "
                                   "channel names, ',', ';' or tab between fields, or MATLAB .mat: dSPACE recorder files, "
                                   "Simulink's structure with time, timeseries fields or vectors beside a time vector), convert the mapped channels to the "
                                   "schema's SI units, resample them onto one grid, align the runs by their steering and "
                                   "write the span they share as an ensemble "
                                   "in the uqdrive data schema, with the files' hashes, the map, the offsets and the "
                                   "steering deviations as provenance.")
    p.add_argument("runs", nargs="+", type=Path, metavar="RUN_FILE",
                   help="one recording per run (.mf4, .mdf, .csv or .mat); with --split, recordings of several runs each")
    p.add_argument("--channels", type=Path, required=True, metavar="MAP.yaml",
                   help="channel map: 'variable: {channel: NAME, units: UNIT[, sign: -1][, steering_ratio: R]}' for "
                        "psi_dot, a_y (any of psi, psi_dot, beta, y, a_y), delta and v; 'time' for CSV files and a MAT "
                        "file's time vector. UNIT may be left out where the files state their units (MDF4; a CSV header "
                        "'NAME [UNIT]' or a units row; a MAT signal's unit field); "
                        "where both give one they must agree (check_units: false keeps the map's)")
    p.add_argument("--out", type=Path, required=True, metavar="ENSEMBLE.nc", help="output netCDF file (its folder must exist)")
    p.add_argument("--vehicle", default=None, metavar="NAME|FILE",
                   help="a packaged vehicle name or vehicle file whose steering_ratio converts the hand-wheel angle when "
                        "the map's delta entry gives none")
    p.add_argument("--dt", type=finite_float("--dt", 1e-6, 10.0, "s"), default=None, metavar="SECONDS",
                   help="step of the output grid in s (default: the fastest mapped channel's period); faster channels "
                        "are low-passed before they are decimated")
    p.add_argument("--align", default="steering", choices=("steering", "none"),
                   help="steering (default): shift each run to match the first file's steering, to a fraction of a "
                        "sample; none: every recording starts at the same instant")
    p.add_argument("--max-steer-deviation", type=finite_float("--max-steer-deviation", 0.0, 100.0), default=None, metavar="X",
                   help="drop the runs whose steering deviates from the ensemble's median by more than X times its RMS "
                        "(default: keep every run and report the deviations)")
    p.add_argument("--split", type=finite_float("--split", 1e-3, 3600.0, "s"), default=None, metavar="REST",
                   help="each file may hold several runs (a logger left running through the session): cut them apart "
                        "where the steering rests for at least REST s (e.g. 2), each named FILE#i; runs whose steering "
                        "lasts much longer or shorter than the median run's (a turn-around, a lane change) are left out "
                        "and listed")
    p.add_argument("--force", action="store_true", help=FORCE_HELP)
    p.set_defaults(run=run_import)


def run_import(args) -> None:
    """Import ``args.runs`` into ``args.out`` and print one line per run."""
    import warnings

    from ..io import check_writable, write_dataset
    from ..recordings.importer import import_runs

    check_writable(args.out, overwrite=args.force)
    ds = import_runs(args.runs, args.channels, vehicle=args.vehicle, dt=args.dt, align=args.align,
                     max_steer_deviation=args.max_steer_deviation, split=args.split)
    write_dataset(ds, args.out, overwrite=args.force)
    for name, why in json.loads(ds.attrs.get("import_split", "{}")).get("skipped", {}).items():
        print(f"{name}: left out, {why}")
    offsets = json.loads(ds.attrs["import_offsets"])
    deviation = json.loads(ds.attrs["import_steer_deviation"])
    dropped, flagged = set(json.loads(ds.attrs["import_dropped"])), json.loads(ds.attrs["import_steer_flagged"])
    for name, offset in offsets.items():
        state = "dropped" if name in dropped else ("deviates" if name in flagged else "kept")
        print(f"{name}: offset {offset:+.4f} s, steering deviation {deviation[name]:.4f} ({state})")
    speed = f"v_c = {ds.attrs['v_c']:.4g} m/s" if "v" not in ds else f"v over {ds['v'].dims}"
    print(f"wrote {args.out}: {ds.sizes['sample']} runs, {ds.sizes['time']} points of {ds.attrs['import_dt']:g} s "
          f"({float(ds['time'][-1]):.4g} s), channels {', '.join(c for c in ('psi', 'psi_dot', 'beta', 'y', 'a_y') if c in ds)}, "
          f"{speed}, steering noise {ds.attrs['import_steer_noise']:.2g} of its RMS")
    kept_flagged = [f for f in flagged if f not in dropped]
    if kept_flagged:
        warnings.warn(f"{len(kept_flagged)} run(s) steer differently from the ensemble by more than the noise (a driver, not a "
                      f"robot?): {', '.join(kept_flagged)}; drop them with --max-steer-deviation", UserWarning, stacklevel=2)

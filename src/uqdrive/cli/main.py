"""Command line of uqdrive: ``simulate`` writes an ensemble in the data schema, ``identify`` fits
the parameter distributions to one.

Errors print one line naming the problem and exit non-zero; no partial output file is left.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ..config import ConfigError, load_config
from ..io import DataError, OutputError, check_writable, write_dataset

__all__ = ["main", "build_parser"]

DEFAULT_CONFIG = Path("config") / "config.yaml"


def _nonneg_float(text: str) -> float:
    value = float(text)
    if not 0.0 <= value <= 1.0:
        raise argparse.ArgumentTypeError(f"noise intensity A must lie in [0, 1], got {text}")
    return value


def _positive_int(text: str) -> int:
    value = int(text)
    if value < 2:
        raise argparse.ArgumentTypeError(f"need at least 2 samples, got {text}")
    return value


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="uqdrive", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    sim = sub.add_parser("simulate", help="simulate a Monte Carlo ensemble (thesis sec. 5.1) into a netCDF file")
    sim.add_argument("--model", required=True, choices=("lst", "nlst"), help="linear (5.4) or non-linear (5.3) single-track model")
    sim.add_argument("--steer", default="normal", choices=("normal", "inverted"), help="steering input (5.5) or (5.7)")
    sim.add_argument("--noise", type=_nonneg_float, default=0.0, metavar="A", help="noise intensity A of (5.6), default 0")
    sim.add_argument("--samples", type=_positive_int, default=None, metavar="N", help="realisations (default: config montecarlo.samples)")
    sim.add_argument("--seed", type=int, default=None, metavar="S", help="root seed (default: config seed)")
    sim.add_argument("--config", type=Path, default=DEFAULT_CONFIG, metavar="FILE", help=f"YAML config (default {DEFAULT_CONFIG})")
    sim.add_argument("--out", type=Path, required=True, metavar="FILE.nc", help="output netCDF file")

    ident = sub.add_parser("identify", help="identify the distributions of mu, l_f and the mean wind from an ensemble (thesis sec. 5.3)")
    ident.add_argument("measured", type=Path, metavar="MEASURED.nc", help="ensemble in the uqdrive data schema (simulated or measured)")
    ident.add_argument("--cost", default="std", choices=("std", "inp", "dst"), help="weights of the cost (5.25): STD, INP (5.26) or DST (5.28)")
    ident.add_argument("--m-load", type=float, default=None, metavar="KG", help="assumed load mass (default: config mean)")
    ident.add_argument("--starts", type=int, default=0, metavar="N", help="extra starting points of a global stage (default 0)")
    ident.add_argument("--state-scale", default=None, choices=("none", "rms_mean", "rms_std"),
                       help="per-state residual scale of (5.25): none (SI units, the thesis) or unit-free (default: config identification.state_scale)")
    ident.add_argument("--config", type=Path, default=DEFAULT_CONFIG, metavar="FILE", help=f"YAML config (default {DEFAULT_CONFIG})")
    ident.add_argument("--out", type=Path, required=True, metavar="DIR", help="output folder for estimate.json and fit.png")
    return parser


def _simulate(args) -> None:
    from ..vehicle.montecarlo import simulate_ensemble
    from ..rng import rng_stream
    from ..vehicle.noise import noisy_ensemble

    config = load_config(args.config)
    check_writable(args.out)
    if args.seed is not None and args.seed < 0:
        raise ConfigError("--seed must be a non-negative integer")
    ds = simulate_ensemble(config, args.model, args.steer, samples=args.samples, seed=args.seed)
    if args.noise > 0:
        seed = ds.attrs["seed"]
        ds = noisy_ensemble(ds, args.noise, rng_stream(seed, "noise", round(args.noise * 1e6)))
    write_dataset(ds, args.out)
    print(f"wrote {args.out}: {args.model.upper()}, {args.steer} steering, {ds.sizes['sample']} samples, "
          f"{ds.attrs['n_spun']} spun, noise A = {args.noise:g}")


def _identify(args) -> None:
    from .identify import identify_file

    config = load_config(args.config)
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise OutputError(f"--out '{out}' exists and is not a folder")
    out.mkdir(parents=True, exist_ok=True)
    check_writable(out / "estimate.json")
    summary = identify_file(config, args.measured, args.cost, args.m_load, args.starts, out, state_scale=args.state_scale)
    state = "converged" if summary["converged"] else "DID NOT CONVERGE"
    print(f"wrote {out / 'estimate.json'}: mu N{tuple(round(v, 4) for v in summary['mu'])}, l_f N{tuple(round(v, 4) for v in summary['l_f'])}, "
          f"F_w_mean U{tuple(round(v, 1) for v in summary['F_w_mean'])} ({state}, {summary['iterations']} iterations)")


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        if args.command == "simulate":
            _simulate(args)
        elif args.command == "identify":
            _identify(args)
    except (ConfigError, DataError, OutputError) as exc:
        print(f"uqdrive: error: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())

"""Benchmark: the chassis right-hand side with its arithmetic compiled
(uqdrive.vehicle.dynamics.fused_chassis, on the linear tyre fused_linear) against the NumPy path
(the baseline, in the same run).

1. One right-hand-side call per chassis term, on the Magic Formula and on the linear tyre, at
   discover's batch sizes (300 realisations: a fit's model; 2400: a Jacobian's), best of
   ``--repeats`` x 300 calls, and whether the numbers are equal.
2. ``discover`` with every candidate on each ``--case`` (default both): a four-wheel case
   (fw_step_030 of docs/four_wheel.md: 500 runs of the independent four-wheel car, no posterior)
   and ``tour``, the README tour's 200 NLST runs (its chassis candidates on the linear tyre, with
   the posterior); CPU seconds of each variant (the NumPy one first, after an untimed warm-up that
   compiles the loops), and whether the two verdicts are equal number for number (their clock
   readings aside).

    python benchmarks/bench_fused_chassis.py [--repeats 3] [--case NAME ...] [--no-discover] [--json FILE] [--machine TEXT]
"""

from __future__ import annotations

import argparse

import numpy as np

from timing import discover_cpu, per_call, record_arguments, report_compiled, without
from uqdrive.config import load_config
from uqdrive.settings import Settings
from uqdrive.vehicle import track_extended
from uqdrive.vehicle.effects import ModelStructure, effect
from uqdrive.vehicle.single_track import VehicleParameters

#: The chassis terms timed per call, each as discover's candidate adds it to the Magic-Formula
#: model, then (after "linear") to the LST's.
TERMS = (("tyre_relaxation",), ("roll_steer",), ("lateral_load_transfer",), ("longitudinal_load_transfer", "combined_slip"), ("compliance_steer",),
         ("load_sensitive_tyre",), ("compliance_steer", "lateral_load_transfer"),
         ("linear", "tyre_relaxation"), ("linear", "roll_steer"), ("linear", "compliance_steer"))
CG_HEIGHT, TRACK_WIDTH = 0.55, 1.6  # m: the four-wheel car's (benchmarks/bench_four_wheel.py)


def _rhs(terms, n: int, fused: bool):
    rng = np.random.default_rng(0)
    linear = terms[0] == "linear"
    s = ModelStructure() if linear else effect("tyre_saturation").augment(ModelStructure(), [0.97])
    for name in terms[linear:]:
        s = effect(name).augment(s, list(effect(name).start))
    p = VehicleParameters.from_settings(Settings.from_config(load_config(None)), mu=rng.uniform(0.6, 1.0, n), l_f=rng.uniform(1.4, 1.7, n),
                                        m_load=rng.normal(100.0, 30.0, n))
    J = 50
    delta = np.deg2rad(3.0) * np.sin(np.linspace(0.0, 3.0, J))
    track_extended.FUSED = fused
    try:
        rhs = track_extended.ExtendedSingleTrackRHS(p, s, 0.97, delta, rng.normal(0.0, 100.0, (J, n)), True, np.zeros(n), CG_HEIGHT, TRACK_WIDTH)
    finally:
        track_extended.FUSED = True
    return rhs, rng.normal(0.0, 0.02, (rhs.n_states, n))


def _calls(terms, n: int, fused: bool, repeats: int, calls: int = 300):
    rhs, x = _rhs(terms, n, fused)
    timed = per_call(rhs, x, repeats, calls)
    assert rhs.fused == fused
    return timed


def four_wheel_case(name: str):
    """The case's ensemble and the config discover reads (the packaged one with the car's cg_height and track width)."""
    from uqdrive.studies.four_wheel import amplitude_for, four_wheel_cases, generate, steady_limit
    from uqdrive.vehicle.four_wheel import FourWheelCar

    config = load_config(None)
    config["vehicle"].update(cg_height=CG_HEIGHT, track_width=TRACK_WIDTH)
    car = FourWheelCar.from_vehicle(Settings.from_config(config).vehicle)
    case = next(c for c in four_wheel_cases(config) if c.name == name)
    return generate(config, case, amplitude_for(config, car, case, steady_limit(config, car)), car), config


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--case", action="append", help="a four-wheel case or tour (repeatable; default fw_step_030 and tour)")
    ap.add_argument("--no-discover", action="store_true")
    record_arguments(ap)
    args = ap.parse_args(argv)
    rows = []
    for terms in TERMS:
        for n in (300, 2400):
            (old, a), (new, b) = _calls(terms, n, False, args.repeats), _calls(terms, n, True, args.repeats)
            rows.append({"case": f"rhs call, {' + '.join(terms).replace('linear + ', 'linear tyre: ')}, {n} realisations", "numpy_s": old, "compiled_s": new, "ratio": old / new,
                         "same": bool(np.array_equal(a, b))})
    for case in [] if args.no_discover else args.case or ["fw_step_030", "tour"]:
        if case == "tour":
            import uqdrive

            runs, kw = uqdrive.simulate("nlst", samples=200), {}
        else:
            runs, config = four_wheel_case(case)
            kw = dict(config=config, candidates="all", posterior=False)
        discover_cpu(track_extended, True, runs.isel(sample=slice(0, 60)), **kw)  # warm-up: imports, numba's cache
        (old, va), (new, vb) = discover_cpu(track_extended, False, runs, **kw), discover_cpu(track_extended, True, runs, **kw)
        rows.append({"case": f"discover, {case}, every candidate (CPU s)", "numpy_s": old, "compiled_s": new, "ratio": old / new,
                     "same": without(va) == without(vb)})
    report_compiled(rows, args, "python benchmarks/bench_fused_chassis.py", 72)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""The chassis model in JAX (vehicle/accelerated/chassis.py, chassis_ensemble.py) on JAX's CPU build
against the NumPy path: its right-hand side with every term alone, in pairs and together, its RK4
ensemble (gusts and a_y on the device), the ensemble simulator's JAX backend (the states and a_y of
its passes), and the device choice of discover and simulate --model."""

import os
import subprocess
import sys

import numpy as np
import pytest

from uqdrive.cli.main import main
from uqdrive.config import load_config
from uqdrive.inference.discrepancy import DiscrepancyFinder
from uqdrive.inference.discrepancy import finder as finder_module
from uqdrive.io import read_ensemble
from uqdrive.numerics import backend
from uqdrive.numerics.integrate import rk4_fixed_step_into
from uqdrive.settings import Settings
from uqdrive.vehicle.augmented import AugmentedSimulator
from uqdrive.vehicle.effects import ModelStructure, effect

from conftest import REPO, tiny_files
from test_fused_chassis import LINEAR_SETS, SENSITIVE, SETS, VALUES, YIELDING, _rates, _rhs, _states, _structure

jax = pytest.importorskip("jax")
from uqdrive.numerics.backend import float64  # noqa: E402
from uqdrive.vehicle.accelerated import chassis, chassis_ensemble  # noqa: E402

# The JAX path runs the NumPy path's equations; they differ by the last bits of the transcendental
# functions and of reordered sums (measured 9e-15 relative on the rates, 2e-15 on 300 RK4 steps,
# the loads' Newton loop and the compliant wheels' included). 1e-10 is the backend's promise.
RTOL = 1e-10
#: Each set once, the inputs taking turns: held speed or braking, numbers or per-realisation.
CASES = [(terms, False, i % 2 == 1, i % 4 >= 2) for i, terms in enumerate(SETS + YIELDING + SENSITIVE)]
CASES += [(terms, True, i % 2 == 1, i % 4 >= 2) for i, terms in enumerate(LINEAR_SETS)]


def _relative(got, expected):
    """Largest |got - expected| of each state over its largest |expected|, the worst state's (-)."""
    return float(np.max(np.abs(got - expected) / np.abs(expected).max(axis=-1, keepdims=True)))


def _jax_rates(rhs, x, j: int, switched: bool = False):
    """dx/dt of :func:`chassis.chassis_rates` at half step ``j``, eagerly (no compilation per set);
    ``switched``: with the terms of :data:`chassis_ensemble.SWITCHED` on, as the passes' programs hold them."""
    c, f = chassis.chassis_constants(rhs)
    if switched:
        c, f = chassis_ensemble.switched_on(c, f)
    v, v_dot = (rhs.speed_half[0][j], rhs.speed_half[1][j]) if rhs.speed_half is not None else (rhs.v, 0.0)
    delta = np.broadcast_to(np.asarray(rhs.delta_half[j], float), x.shape[1:])
    with float64():
        return np.stack(chassis.chassis_rates({k: jax.numpy.asarray(a) for k, a in c.items()}, f, tuple(jax.numpy.asarray(x)),
                                              jax.numpy.asarray(delta), jax.numpy.asarray(rhs.F_w_half[j]), v, v_dot))


@pytest.mark.parametrize("terms, linear, speed, per_run", CASES,
                         ids=lambda a: "+".join(a) if isinstance(a, tuple) else str(a))
def test_the_jax_chassis_rates_are_the_numpy_rates(terms, linear, speed, per_run):
    """Tyres past their peak, wheels lifting, relaxation lengths of zero among per-run ones: every
    state's rate within RTOL of the NumPy reference's (FUSED off) at a half step, and bit for bit
    those of the program that holds every switched term."""
    extra = ("road_bank", "lateral_kinematics") if per_run else ()
    s = _structure(terms + extra, np.random.default_rng(2) if per_run else None, linear=linear)
    reference = _rhs(False, s, speed=speed, per_run=per_run)
    x = _states(reference, np.random.default_rng(3))
    if linear:
        x[0] = np.clip(x[0], -2.5, 2.5)
    expected = _rates(reference, x, (1,))[0]
    assert np.all(np.isfinite(expected))
    assert _relative(_jax_rates(reference, x, 1), expected) < RTOL
    # the passes' programs hold the load and compliance terms whether on or not: off, the same doubles
    np.testing.assert_array_equal(_jax_rates(reference, x, 1, switched=True), _jax_rates(reference, x, 1))


@pytest.mark.parametrize("term", ["lateral_load_transfer", "combined_slip", "roll_steer", "tyre_relaxation", "load_sensitive_tyre"])
def test_the_comparison_sees_a_term_left_out(term, monkeypatch):
    """With a term's flag off in the JAX program its rates leave the reference by far more than RTOL."""
    s = _structure((term,) + (("longitudinal_load_transfer",) if term == "combined_slip" else ()))
    reference = _rhs(False, s, speed=True)
    x = _states(reference, np.random.default_rng(3))
    flag = {"lateral_load_transfer": "transferring", "combined_slip": "slipping", "roll_steer": "rolling", "tyre_relaxation": "relaxed",
            "load_sensitive_tyre": "sensitive"}[term]
    constants = chassis.chassis_constants
    monkeypatch.setattr(chassis, "chassis_constants", lambda rhs: (constants(rhs)[0], {**constants(rhs)[1], flag: False}))
    if term in ("roll_steer", "tyre_relaxation"):  # the extra states' rows then missing: compare the four shared ones
        assert _relative(_jax_rates(reference, x, 1)[:4], _rates(reference, x, (1,))[0][:4]) > 1e3 * RTOL
    else:
        assert _relative(_jax_rates(reference, x, 1), _rates(reference, x, (1,))[0]) > 1e3 * RTOL


@pytest.mark.parametrize("linear", [False, True], ids=["magic formula", "linear tyre"])
def test_the_jax_ensemble_is_the_numpy_ensemble(linear):
    """Relaxation, roll steer, the loads' loop and (linear tyre) compliance steer over 20 RK4 steps
    from rest, braking, per-realisation inputs, recorded every second step, the gusts formed on the
    device from their modes: the states and a_y; 53 realisations are padded to the program's 64 and cut back."""
    terms = ("tyre_relaxation", "roll_steer", "compliance_steer", "lateral_load_transfer") if linear else \
        ("tyre_relaxation", "roll_steer", "lateral_load_transfer", "combined_slip", "longitudinal_load_transfer")
    rhs = _rhs(True, _structure(terms, linear=linear), speed=True, per_run=True)
    rng = np.random.default_rng(11)
    wind, coeffs = rng.uniform(-200.0, 200.0, 53), rng.normal(0.0, 150.0, (53, 3))
    modes = np.stack([np.sin((i + 1) * np.linspace(0.0, 3.0, 41)) for i in range(3)])  # (n_c, J)
    rhs.F_w_half = wind + (coeffs @ modes).T  # the NumPy path's wind table
    expected = rk4_fixed_step_into(rhs, np.zeros((rhs.n_states, 53)), 0.01, 20, 2)
    a_y = np.stack([rhs.lateral_acceleration(np.ascontiguousarray(expected[k]), 4 * k) for k in range(11)], axis=-1)
    got, got_a_y = chassis_ensemble.integrate_chassis_jax(rhs, 0.01, 20, 2, wind, coeffs, modes, lateral_acceleration=True)
    assert got.shape == (11, 4, 53) and got_a_y.shape == a_y.shape == (53, 11)
    assert np.abs(expected[-1, 1]).max() > 1e-3 and np.abs(a_y).max() > 0.5  # the car turned
    assert _relative(got.transpose(1, 2, 0).reshape(4, -1), expected[:, :4].transpose(1, 2, 0).reshape(4, -1)) < RTOL
    assert _relative(got_a_y, a_y) < RTOL
    programs = chassis_ensemble.programs_compiled()
    again, none = chassis_ensemble.integrate_chassis_jax(rhs, 0.01, 20, 2, wind, coeffs, modes, lateral_acceleration=True)
    np.testing.assert_array_equal(again, got)  # the same program, the same bits
    assert chassis_ensemble.programs_compiled() == programs >= 1 and none is not None
    if linear:  # the program that holds every switched term (this pass has some off): its own, the same numbers
        shared, shared_a_y = chassis_ensemble.integrate_chassis_jax(rhs, 0.01, 20, 2, wind, coeffs, modes, lateral_acceleration=True,
                                                                    share_programs=True)
        assert chassis_ensemble.programs_compiled() == programs + 1
        assert _relative(shared.transpose(1, 2, 0).reshape(4, -1), got.transpose(1, 2, 0).reshape(4, -1)) < RTOL
        assert _relative(shared_a_y, got_a_y) < RTOL
    with pytest.raises(ValueError, match="multiple"):
        chassis_ensemble.integrate_chassis_jax(rhs, 0.01, 20, 3, wind, coeffs, modes)


def test_the_simulators_jax_backend_gives_the_cpu_numbers(monkeypatch):
    """An augmented simulator's passes along a speed profile with a_y measured (a_y from the
    states on the CPU): a chassis structure, the Magic Formula alone and a batch of two pairs; the
    exact linear model stays on the CPU."""
    cfg = load_config(None)
    cfg["vehicle"].update(cg_height=0.55, track_width=1.6)
    settings = Settings.from_config(cfg)
    t = np.arange(0.0, 3.0 + 1e-9, 0.01)
    delta = np.deg2rad(3.0) * np.sin(2 * np.pi * t / 1.5)
    sims = {b: AugmentedSimulator.drawn(settings, t, delta, 25.0, 40, np.random.default_rng(1), stride=2, channels=("psi_dot", "beta", "a_y"),
                                        speed=np.linspace(25.0, 20.0, t.size), backend=b) for b in ("numpy", "jax")}
    theta = list(settings.layout.start)
    tyre = effect("tyre_saturation").augment(ModelStructure(), [0.97])
    relaxing = effect("tyre_relaxation").augment(tyre, VALUES["tyre_relaxation"])
    loaded = effect("lateral_load_transfer").augment(relaxing, VALUES["lateral_load_transfer"])
    passes, integrate = [], chassis_ensemble.integrate_chassis_jax
    monkeypatch.setattr(chassis_ensemble, "integrate_chassis_jax", lambda *a: passes.append(1) or integrate(*a))
    for s in (tyre, loaded):
        expected = sims["numpy"].simulate(theta, s)
        assert np.abs(expected[2]).max() > 0.5  # a_y of a car that turns (m/s^2)
        assert _relative(sims["jax"].simulate(theta, s).reshape(3, -1), expected.reshape(3, -1)) < RTOL
    assert len(passes) == 2  # the JAX backend's passes, the CPU's none
    pairs = ([theta, theta], [relaxing, effect("tyre_relaxation").augment(tyre, [0.2])])
    for got, expected in zip(sims["jax"].simulate_many(*pairs), sims["numpy"].simulate_many(*pairs)):
        assert _relative(got.reshape(3, -1), expected.reshape(3, -1)) < RTOL
    with pytest.raises(ValueError, match="backend"):
        AugmentedSimulator.drawn(settings, t, delta, 25.0, 4, np.random.default_rng(1), backend="cuda")


def test_discover_on_a_gpu_fits_in_one_process_and_refuses_a_missing_gpu(tmp_path, capsys, monkeypatch):
    """device gpu: the JAX backend, the fits in this process whatever jobs asks (a forked worker
    cannot use the GPU); without a GPU the command refuses in one line naming the install, before reading the data."""
    settings = Settings.from_config(load_config(None))
    monkeypatch.setattr(backend, "gpu_visible", lambda: True)
    finder = DiscrepancyFinder(settings, jobs=2, device="gpu")
    assert (finder.backend, finder.jobs) == ("jax", 1)
    assert (DiscrepancyFinder(settings, jobs=2).backend, DiscrepancyFinder(settings, jobs=2).jobs) == ("numpy", 2)
    data = tiny_files(tmp_path)[1]

    def drawn(*args, backend="numpy", **kwargs):  # stops the fit where it builds its simulator, naming the backend
        raise LookupError(backend)

    monkeypatch.setattr(finder_module.AugmentedSimulator, "drawn", drawn)
    with pytest.raises(LookupError, match="^jax$"):  # the fit's simulator is built for JAX
        finder.fit(read_ensemble(data))
    monkeypatch.setattr(backend, "gpu_visible", lambda: False)
    rc = main(["discover", str(tmp_path / "missing.nc"), "--device", "gpu", "--out", str(tmp_path / "out"), "--config", str(REPO / "config" / "test.yaml")])
    err = capsys.readouterr().err
    assert rc == 2 and err.count("\n") == 1 and "uqdrive[gpu]" in err and "device" in err
    assert not (tmp_path / "out").exists()


def test_the_command_line_keeps_jaxs_programs_on_disk(tmp_path):
    """--device's JAX choice names a disk cache (XDG_CACHE_HOME/uqdrive/jax) that a compiled
    program is written to, and keeps a cache the process already names."""
    code = ("import jax; from uqdrive.cli.validation import compilation_cache; print(compilation_cache()); "
            "print(compilation_cache('/elsewhere')); jax.jit(lambda x: x * 2.0 + 1.0)(3.0).block_until_ready()")
    env = {**os.environ, "XDG_CACHE_HOME": str(tmp_path), "JAX_PLATFORMS": "cpu"}
    env.pop("JAX_COMPILATION_CACHE_DIR", None)
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=120)
    directory = tmp_path / "uqdrive" / "jax"
    assert run.returncode == 0, run.stderr
    assert run.stdout.split() == [str(directory)] * 2
    assert any(directory.iterdir())  # the program, compiled in well under JAX's default one second, is kept


def test_simulating_a_discovered_model_on_the_gpu_gives_the_cpu_numbers(tmp_path, monkeypatch):
    """`uqdrive simulate --model gap/model.yaml --device gpu`: the augmented model (a saturating,
    relaxing tyre) integrated by JAX within RTOL of the CPU path, every state."""
    import yaml

    import uqdrive
    from uqdrive.vehicle.effects import EFFECTS

    effects = {"tyre_saturation": [0.97], "tyre_relaxation": VALUES["tyre_relaxation"]}
    model = {"uqdrive_model": 1, "baseline": "lst", "effects": {k: dict(zip(EFFECTS[k].parameters, v)) for k, v in effects.items()},
             "distributions": {"mu": {"mean": 1.0, "std": 0.1}, "l_f": {"mean": 1.55, "std": 0.1}, "F_w_mean": {"low": -400.0, "high": 400.0}}}
    path = tmp_path / "model.yaml"
    path.write_text(yaml.safe_dump(model))
    config = REPO / "config" / "test.yaml"
    expected = uqdrive.simulate(path, config=config, samples=8)
    monkeypatch.setattr(backend, "gpu_visible", lambda: True)
    passes, integrate = [], chassis_ensemble.integrate_chassis_jax
    monkeypatch.setattr(chassis_ensemble, "integrate_chassis_jax", lambda *a: passes.append(1) or integrate(*a))
    got = uqdrive.simulate(path, config=config, samples=8, device="gpu")
    assert passes and float(np.abs(expected["beta"].values).max()) > 1e-3  # JAX's pass; the car turned
    for name in ("psi", "psi_dot", "beta", "y"):
        assert _relative(got[name].values, expected[name].values) < RTOL


def test_on_an_accelerator_one_width_serves_a_searchs_passes(monkeypatch):
    """Padded to ACCELERATOR_MIN_WIDTH where JAX's device is not the CPU (passes of a few hundred
    realisations are launch-bound there): 53 and 300 realisations run in one program of that width,
    with the numbers of the CPU build's 64-wide program; more than it take the next power of two."""
    wide = chassis_ensemble.ACCELERATOR_MIN_WIDTH
    assert chassis_ensemble.program_width(53) == 64 and chassis_ensemble.program_width(300, accelerator=True) == wide
    assert chassis_ensemble.program_width(wide + 1, accelerator=True) == 2 * wide
    rng = np.random.default_rng(11)
    modes = np.stack([np.sin((i + 1) * np.linspace(0.0, 3.0, 41)) for i in range(3)])

    def run(n):
        rhs = _rhs(True, _structure(("tyre_relaxation",)), n=n, speed=True)
        return chassis_ensemble.integrate_chassis_jax(rhs, 0.01, 20, 2, rng.uniform(-200.0, 200.0, n), rng.normal(0.0, 150.0, (n, 3)),
                                                      modes)[0]

    rng = np.random.default_rng(11)
    narrow = run(53)
    programs = chassis_ensemble.programs_compiled()
    monkeypatch.setattr(jax, "default_backend", lambda: "gpu")
    rng = np.random.default_rng(11)
    padded = run(53)
    assert chassis_ensemble.programs_compiled() == programs + 1
    run(300)
    assert chassis_ensemble.programs_compiled() == programs + 1  # the same program
    assert _relative(padded.transpose(1, 2, 0).reshape(4, -1), narrow.transpose(1, 2, 0).reshape(4, -1)) < RTOL

"""The ensemble's device choice and the JAX path: the device names resolve as documented (a GPU
asked for and missing is one line naming the fix), and JAX on its CPU build gives the NumPy
path's numbers for the default config's NLST ensemble, at constant speed and along a speed profile."""

import copy

import numpy as np
import pytest

from uqdrive.cli.main import main
from uqdrive.numerics import backend
from uqdrive.numerics.backend import GPU_INSTALL, DeviceError, resolve_device
from uqdrive.settings import Settings
from uqdrive.vehicle import montecarlo
from uqdrive.vehicle.montecarlo import simulate_ensemble
from uqdrive.vehicle.single_track import STATES

from conftest import REPO

# The two paths run the same operations in the same order; they differ by the last bits of the
# transcendental functions (XLA's against NumPy's, ~1 ulp) and of the gusts' sums, carried by a
# damped recursion over 2000 steps: measured 3e-15 relative. 1e-10 is the backend's promise.
RTOL = 1e-10
SAMPLES = 64


def _relative_difference(a, b):
    """Largest |a - b| of each variable over its largest |b|, the worst variable's (-)."""
    return max(float(np.abs(a[v].values - b[v].values).max() / np.abs(b[v].values).max()) for v in (*STATES, "a_y"))


@pytest.fixture
def no_gpu(monkeypatch):
    monkeypatch.setattr(backend, "gpu_visible", lambda: False)


def test_device_names_resolve(monkeypatch, no_gpu):
    assert resolve_device("cpu") == "numpy" and resolve_device("auto") == "numpy"
    monkeypatch.setattr(backend, "gpu_visible", lambda: True)
    monkeypatch.setattr(backend, "jax_installed", lambda: True)
    assert resolve_device("auto") == "jax" and resolve_device("gpu") == "jax" and resolve_device("cpu") == "numpy"
    with pytest.raises(DeviceError, match="choose one of auto, cpu, gpu"):
        resolve_device("cuda")


@pytest.mark.parametrize("installed", [False, True])
def test_gpu_asked_for_and_missing_is_one_line_naming_the_fix(monkeypatch, no_gpu, installed):
    monkeypatch.setattr(backend, "jax_installed", lambda: installed)
    with pytest.raises(DeviceError) as caught:
        resolve_device("gpu")
    message = str(caught.value)
    assert GPU_INSTALL in message and "\n" not in message
    assert ("not installed" in message) != installed and ("sees no GPU" in message) == installed


def test_the_command_refuses_a_missing_gpu_before_writing(tmp_path, capsys, no_gpu):
    out = tmp_path / "x.nc"
    rc = main(["simulate", "--model", "nlst", "--samples", "4", "--device", "gpu", "--config", str(REPO / "config" / "test.yaml"),
               "--out", str(out)])
    err = capsys.readouterr().err
    assert rc == 2 and err.count("\n") == 1 and "uqdrive[gpu]" in err and "device" in err
    assert not out.exists()


def test_auto_without_a_gpu_is_the_numpy_path_bit_for_bit(config, monkeypatch, no_gpu):
    settings = Settings.from_config(config)
    called = []
    realise = montecarlo.EnsembleSimulator.realise
    monkeypatch.setattr(montecarlo.EnsembleSimulator, "realise", lambda *a, **k: called.append(1) or realise(*a, **k))
    auto = simulate_ensemble(settings, "nlst", samples=8, device="auto")
    cpu = simulate_ensemble(settings, "nlst", samples=8, device="cpu")
    assert called == [1, 1]
    for name in (*STATES, "a_y"):
        assert np.array_equal(auto[name].values, cpu[name].values)
    assert auto.attrs == cpu.attrs and auto.attrs["integrator"] == "classical RK4"


@pytest.mark.parametrize("profile", [None, {"start_kmh": 70.0, "end_kmh": 45.0, "t_start": 2.0, "duration": 3.0}],
                         ids=["constant speed", "speed profile"])
def test_jax_gives_the_numpy_numbers(config, monkeypatch, profile):
    pytest.importorskip("jax")
    cfg = copy.deepcopy(config)
    if profile is not None:
        cfg["montecarlo"]["speed_profile"] = profile
    settings = Settings.from_config(cfg)
    reference = simulate_ensemble(settings, "nlst", samples=SAMPLES)
    monkeypatch.setattr(montecarlo, "resolve_device", lambda device: "jax")  # JAX on whatever device it has
    on_jax = simulate_ensemble(settings, "nlst", samples=SAMPLES, device="gpu")
    assert on_jax.attrs["integrator"] == "classical RK4 (JAX, float64)"
    assert reference["beta"].values.std() > 1e-3  # the slalom is simulated, not a state at rest
    assert _relative_difference(on_jax, reference) < RTOL
    for name in ("mu", "l_f", "F_w_mean", "xi_wind", "spun"):
        assert np.array_equal(on_jax[name].values, reference[name].values)


def test_the_comparison_sees_a_wrong_right_hand_side(config, monkeypatch):
    """A tyre force of the wrong sign in the JAX right-hand side is far outside the tolerance."""
    jax = pytest.importorskip("jax")
    from uqdrive.vehicle.accelerated import nlst

    settings = Settings.from_config(config)
    reference = simulate_ensemble(settings, "nlst", samples=SAMPLES)
    monkeypatch.setattr(montecarlo, "resolve_device", lambda device: "jax")
    force = nlst._curved_slip_force
    monkeypatch.setattr(nlst, "_curved_slip_force", lambda peak, *a: force(-peak, *a))
    jax.clear_caches()  # the compiled ensemble traced the true right-hand side
    try:
        wrong = simulate_ensemble(settings, "nlst", samples=SAMPLES, device="gpu")
    finally:
        jax.clear_caches()
    assert _relative_difference(wrong, reference) > 1e3 * RTOL

"""The four-wheel reality against textbook limits: the linear single-track yaw-rate gain and
understeer gradient at small lateral acceleration (Gillespie, Rajamani eq. (3.1x)), lateral and
longitudinal load transfer at constant acceleration, and the friction limit a_y <= mu g."""

from dataclasses import replace

import numpy as np
import pytest

from uqdrive.config import ConfigError
from uqdrive.vehicle.four_wheel.model import PHI, R, TH, VX, VY, FourWheelCar, simulate_four_wheel
from uqdrive.vehicle.four_wheel.tyre import cornering_stiffness, lateral_force, peak_force
from uqdrive.settings import Settings

V = 70.0 / 3.6
M = 1884.0  # kg, m_base + the 100 kg load of every run below
G = 9.81
L_F = 1.55
CAR = FourWheelCar()


def _run(car, delta, t_end, mu=1.0, v_ref=None, h=0.01, every=5):
    """One realisation (nominal load and l_f, no wind); delta, v_ref: functions of t."""
    n_steps = int(round(t_end / h))
    t_half = np.arange(2 * n_steps + 1) * h / 2
    zero = np.zeros((t_half.size, 1))
    v = np.full_like(t_half, V) if v_ref is None else v_ref(t_half)
    x, extras = simulate_four_wheel(car, np.array([mu]), np.array([100.0]), np.array([L_F]), delta(t_half), v, zero, zero, h, n_steps, every)
    return x[:, 0], {k: v[..., 0, :] for k, v in extras.items()}


def _textbook_understeer(car):
    """K = m / L (l_r / C_f - l_f / C_r) (rad s^2/m), C = F_z B C mu per axle at mu = 1."""
    L = car.wheelbase
    l_r = L - L_F
    C_f = M * G * l_r / L * car.B_f * car.C
    C_r = M * G * L_F / L * car.B_r * car.C
    return M / L * (l_r / C_f - L_F / C_r)


def _roll_steer_understeer(car):
    """(e_f + e_r) dphi/da_y, with the steady roll phi = m h a_y / (K_phi - m g h)."""
    return (car.roll_steer_front + car.roll_steer_rear) * M * car.cg_height / (car.roll_stiffness - M * G * car.cg_height)


@pytest.mark.parametrize("roll_steer", [0.0, 0.08])
def test_small_lateral_acceleration_gives_the_linear_single_track_gain(roll_steer):
    """Step steer of 0.002 rad (a_y ~ 0.18 m/s^2, 2 % of mu g): the steady yaw-rate gain is
    v / (L + K v^2) and (delta - L r / v) / a_y is K (plus the roll steer's share).

    Without rolling resistance and drag the model is the textbook's up to the slip angles'
    second-order terms (measured 1e-4): tolerance 1e-3. With them, the drag's pitch moment moves
    ~30 N from the front to the rear axle and the rolling resistance of the steered wheels turns
    against the lateral force (each ~0.2 %): tolerance 1 % on the gain, 3 % on K."""
    car = replace(CAR, roll_steer_front=roll_steer)
    K = _textbook_understeer(car) + _roll_steer_understeer(car)
    gain = V / (car.wheelbase + K * V**2)
    d = 0.002
    for c, tol in ((replace(car, drag_area=0.0, rolling_resistance=0.0), 1e-3), (car, 1e-2)):
        x, ex = _run(c, lambda t: d * np.clip(t, 0.0, 1.0), 10.0)
        r, a_y = x[R, -1], ex["a_y"][-1]
        assert abs(r / d / gain - 1) < tol, (r / d, gain)
        assert abs((d - c.wheelbase * r / V) / a_y / K - 1) < 3 * tol
    # the roll steer is there: it changes the gain by more than the tolerance
    assert abs(_roll_steer_understeer(replace(CAR, roll_steer_front=0.08)) / _textbook_understeer(CAR)) > 0.1


def test_lateral_load_transfer_in_a_steady_turn():
    """Steady turn at a_y ~ 2.6 m/s^2: the roll springs carry sum_i dF_i t = m h (a_y + g phi)
    (the textbook m a_y h / t plus the centre of gravity's lateral shift h phi), split in the
    roll-stiffness distribution K_phi,f / K_phi; the shift is mgh / (K_phi - mgh) = 7.8 % of
    the textbook value here. Tolerance 1e-4 relative (RK4 and the 10 s settling)."""
    x, ex = _run(CAR, lambda t: 0.03 * np.clip(t, 0.0, 1.0), 10.0)
    F_z, a_y, phi = ex["F_z"][:, -1], ex["a_y"][-1], x[PHI, -1]
    h, t_w = CAR.cg_height, CAR.track_width
    dF_f, dF_r = (F_z[1] - F_z[0]) / 2, (F_z[3] - F_z[2]) / 2  # right (outer) minus left, per wheel
    assert a_y > 2.0
    assert abs((dF_f + dF_r) * t_w / (M * h * (a_y + G * np.sin(phi))) - 1) < 1e-4
    assert abs(dF_f / (dF_f + dF_r) - CAR.roll_stiffness_front / CAR.roll_stiffness) < 1e-4
    shift = M * G * h / (CAR.roll_stiffness - M * G * h)
    assert abs((dF_f + dF_r) * t_w / (M * a_y * h) - (1 + shift)) < 2e-3


def test_longitudinal_load_transfer_when_accelerating():
    """The controller follows a speed ramp of 1 m/s^2: the rear axle gains
    (h (m a_x + F_drag) + m g h theta) / L, the textbook m a_x h / L plus the drag's and the
    pitch's share (tolerance 1e-3 relative); a steady front-to-rear shift, not a transient."""
    x, ex = _run(CAR, lambda t: 0.0 * t, 10.0, v_ref=lambda t: V + 1.0 * np.clip(t - 1.0, 0.0, None))
    F_z, a_x, theta, vx = ex["F_z"][:, -1], ex["a_x"][-1], x[TH, -1], x[VX, -1]
    h, L = CAR.cg_height, CAR.wheelbase
    drag = 0.5 * CAR.air_density * CAR.drag_area * vx**2
    gained = F_z[2] + F_z[3] - M * G * L_F / L
    assert abs(a_x - 1.0) < 0.05  # the PI follows the ramp (its steady error is a constant speed lag)
    assert abs(gained / ((h * (M * a_x + drag) + M * G * h * np.sin(theta)) / L) - 1) < 1e-3
    assert gained > M * a_x * h / L  # front -> rear


@pytest.mark.parametrize("mu", [1.0, 0.5])
def test_lateral_acceleration_stays_below_the_friction_limit(mu):
    """A slow ramp steer to 30 deg: max |a_y| <= mu g, and above 0.8 mu g (the load sensitivity
    p_Dz = -0.1 and the lateral transfer lower the front axle's peak; measured 0.86 at mu = 1,
    0.93 at mu = 0.5)."""
    _, ex = _run(CAR, lambda t: np.deg2rad(30.0) * np.clip(t / 15.0, 0.0, 1.0), 12.0, mu=mu, h=0.005, every=10)
    peak = np.abs(ex["a_y"]).max() / (mu * G)
    assert 0.8 < peak <= 1.0, peak


def test_tyre_is_load_sensitive_and_degressive():
    """D / F_z falls with load for p_Dz < 0, K_y grows less than proportionally, and the
    Magic Formula's slope at zero slip is K_y (finite difference, 1e-6)."""
    F0 = np.array([4000.0])
    F = np.array([2000.0, 4000.0, 6000.0])
    D = peak_force(F, F0, 1.0, -0.1)
    assert np.all(np.diff(D / F) < 0)
    K = cornering_stiffness(F, F0, 80e3, 2.0)
    assert K[1] == pytest.approx(80e3) and np.all(np.diff(K / F) < 0) and np.all(np.diff(K) > 0)
    eps = 1e-7
    assert lateral_force(eps, D, K, 1.9, 0.97) / eps == pytest.approx(K, rel=1e-6)


def test_from_config_needs_cg_height(config):
    """The vehicle section's cg_height is required, with an error naming it."""
    cfg = {**config, "vehicle": {k: v for k, v in config["vehicle"].items() if k != "cg_height"}}
    with pytest.raises(ConfigError, match="cg_height"):
        FourWheelCar.from_vehicle(Settings.from_config(cfg).vehicle)
    car = FourWheelCar.from_vehicle(Settings.from_config({**config, "vehicle": {**config["vehicle"], "cg_height": 0.5, "track_width": 1.5}}).vehicle)
    assert (car.cg_height, car.track_width, car.B_f) == (0.5, 1.5, config["vehicle"]["c_Sf"])


def test_side_slip_and_position_outputs_are_consistent():
    """beta = atan(vy / vx) and Y' = v sin(psi + beta): a steady turn's Y follows the integral."""
    x, _ = _run(CAR, lambda t: 0.01 * np.clip(t, 0.0, 1.0), 4.0, h=0.005, every=2)
    beta = np.arctan2(x[VY], x[VX])
    v = np.hypot(x[VX], x[VY])
    dY = v * np.sin(x[0] + beta)
    Y = np.concatenate([[0.0], np.cumsum(0.5 * (dY[1:] + dY[:-1]) * 0.01)])
    assert np.abs(Y - x[4]).max() < 1e-3 * np.abs(x[4]).max()


def test_case_files_follow_the_data_schema_and_carry_no_label(config):
    """A short case: valid in the data schema, the same file from the same seed, nothing in it
    that names the reality's constants or the case."""
    from uqdrive.io import validate_ensemble
    from uqdrive.studies.four_wheel import FourWheelCase, generate

    cfg = {**config, "vehicle": {**config["vehicle"], "cg_height": 0.55, "track_width": 1.6}}
    case = FourWheelCase("fw_probe", "slalom", 0.5, {"period": 2.0}, samples=8, seed=3, t_end=1.0)
    ds = generate(cfg, case, 3.0)
    validate_ensemble(ds, "four-wheel case")
    assert set(ds.data_vars) == {"psi", "psi_dot", "beta", "y", "a_y", "delta"}
    assert "fw_probe" not in str(ds.attrs) and not any(k in ds.attrs for k in ("effect", "label", "car"))
    assert np.array_equal(generate(cfg, case, 3.0).psi_dot.values, ds.psi_dot.values)
    with pytest.raises(ValueError, match="level"):
        FourWheelCase("x", "step", 1.2)

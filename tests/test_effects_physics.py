"""The chassis effects of a real car enter the augmented single-track model as their physics says:
each test derives the steady state (or the step response) from the effect's equation on its own
and fails when the term is removed from the model or its sign is flipped."""

from dataclasses import replace

import numpy as np
import pytest

from uqdrive.config import ConfigError
from uqdrive.vehicle.augmented import AugmentedSimulator
from uqdrive.vehicle.effects import EFFECTS, ModelStructure, effect
from uqdrive.vehicle.single_track import VehicleParameters
from uqdrive.settings import Settings

THETA = [0.8, 0.0, 1.55, 0.0, 0.0, 0.0]  # one car: no spread, no mean wind
V = 70.0 / 3.6
H, T_W = 0.55, 1.6
DT = 0.01


def _simulator(config, delta, t_end=8.0, v=V):
    cfg = {**config, "vehicle": {**config["vehicle"], "cg_height": H, "track_width": T_W}}
    t = np.arange(int(round(t_end / DT)) + 1) * DT
    sim = AugmentedSimulator.drawn(Settings.from_config(cfg), t, delta(t), v, 2, np.random.default_rng(0))
    sim.sigma = 0.0  # no gusts: a steady state
    return sim, t


def _steady(config, structure, delta_deg=4.0, v=V):
    sim, _ = _simulator(config, lambda t: np.deg2rad(delta_deg) * np.clip(t - 0.5, 0.0, 1.0), v=v)
    x = sim.simulate(THETA, structure)
    assert np.abs(x[1, 0, -1] - x[1, 0, -50]) < 1e-7  # settled
    return x[1, 0, -1], x[2, 0, -1], np.deg2rad(delta_deg)


def _saturating(**fields):
    s = effect("tyre_saturation").augment(ModelStructure(), [0.97])
    for name, values in fields.items():
        s = effect(name).augment(s, values)
    return s


def _foh_response(A, b, u):
    """States (n, T) of x' = A x + b u from rest with u (T,) linear between the DT samples (Van
    Loan: the input u0 + (u1 - u0) tau / DT, integrated exactly by the matrix exponential)."""
    from scipy.linalg import expm

    n = len(A)
    M = np.zeros((n + 2, n + 2))
    M[:n, :n], M[:n, n], M[n, n + 1] = A, b, 1.0 / DT
    E = expm(M * DT)
    out, z = [np.zeros(n)], np.zeros(n)
    for j in range(u.size - 1):
        z = E[:n, :n] @ z + E[:n, n] * u[j] + E[:n, n + 1] * (u[j + 1] - u[j])
        out.append(z)
    return np.array(out).T


def _equilibrium_residual(config, r, beta, delta, loads, v=V):
    """Yaw-moment and lateral-force balance of (5.3) at the steady state (r, beta) with axle
    loads ``loads(p, r, beta)`` (effective peak loads, N), relative to the front force."""
    V = v
    p = VehicleParameters.from_settings(Settings.from_config(config), mu=THETA[0], l_f=THETA[2], v_c=V)
    P_f, P_r = loads(p, r, beta)
    a_f = delta - np.arctan((V * np.sin(beta) + p.l_f * r) / (V * np.cos(beta)))
    a_r = -np.arctan((V * np.sin(beta) - p.l_r * r) / (V * np.cos(beta)))
    mf = lambda a, B: p.mu * np.sin(p.C * np.arctan(B * a - p.E * (B * a - np.arctan(B * a))))  # noqa: E731
    F_f, F_r = P_f * mf(a_f, p.c_Sf) * np.cos(delta), P_r * mf(a_r, p.c_Sr)
    yaw = (p.l_f * F_f - p.l_r * F_r) / (p.l_f * F_f)
    lateral = ((F_f + F_r) * np.cos(beta) / (p.m * V) - r) / r
    return max(abs(yaw), abs(lateral))


def _longitudinal_loads(h, sign=1.0):
    def loads(p, r, beta):
        a_x = -np.tan(beta) * p.v_c * r / np.cos(beta)  # -tan(beta) a_y, the tyres' a_y = v r / cos(beta) at steady state
        shift = sign * p.m * a_x * h / p.wheelbase  # F_zf = m (g l_r - a_x h) / L
        return p.F_fz - shift, p.F_rz + shift
    return loads


def _lateral_loads(chi, p_Dz, sign=1.0):
    def loads(p, r, beta):
        a_y = p.v_c * r / np.cos(beta)  # the tyres' lateral force over m at steady state: beta_dot = 0 in (5.3)
        out = []
        for F, share in ((p.F_fz, chi), (p.F_rz, 1.0 - chi)):
            dF = share * p.m * a_y * H / T_W  # per wheel
            F0 = F / 2
            wheels = np.array([F0 - dF, F0 + dF])
            out.append(np.sum(wheels * (1.0 + sign * p_Dz * (wheels - F0) / F0)))  # Pacejka (4.E13) per wheel
        return out
    return loads


def test_longitudinal_load_transfer_moves_load_by_m_a_x_h_over_L(config):
    """At 70 km/h this car's steady side slip stays below 0.01 rad, and a_x = -tan(beta) a_y
    (a_y = v r / cos(beta), the tyres' force at beta_dot = 0) moves a few newtons; at 140 km/h and mu 0.8 (beta ~ -0.03, a_y ~ 6 m/s^2) it moves ~1 % of
    the front load. The steady state balances with F_zf = m (g l_r - a_x h) / L to 1e-6 (RK4 and
    settling) and misses it by > 1e-3 with static loads or the shift's sign flipped."""
    h, v = 1.0, 140.0 / 3.6
    r, beta, delta = _steady(config, _saturating(longitudinal_load_transfer=[h]), delta_deg=3.0, v=v)
    assert beta < -0.01
    assert _equilibrium_residual(config, r, beta, delta, _longitudinal_loads(h), v) < 1e-6
    assert _equilibrium_residual(config, r, beta, delta, _longitudinal_loads(0.0), v) > 1e-3
    assert _equilibrium_residual(config, r, beta, delta, _longitudinal_loads(h, -1.0), v) > 1e-3
    assert EFFECTS["longitudinal_load_transfer"].prior_start(replace(Settings.from_config(config).vehicle, cg_height=0.61)) == (0.61,)


def test_lateral_load_transfer_with_load_sensitivity(config):
    """a_y ~ 6 m/s^2: per wheel dF = chi h T / t (T = m v r / cos(beta), the tyres' lateral force
    at the steady state) and the peak mu F_z (1 + p_Dz dfz) give the
    axle force; the steady state balances with them to 1e-6 and misses by > 1e-3 without the
    transfer or with p_Dz's sign flipped. chi_f above l_r / L adds understeer: less yaw rate."""
    chi, p_Dz = 0.7, -0.3
    r, beta, delta = _steady(config, _saturating(lateral_load_transfer=[chi, p_Dz]))
    assert V * r > 5.0
    assert _equilibrium_residual(config, r, beta, delta, _lateral_loads(chi, p_Dz)) < 1e-6
    assert _equilibrium_residual(config, r, beta, delta, _lateral_loads(chi, 0.0)) > 1e-3
    assert _equilibrium_residual(config, r, beta, delta, _lateral_loads(chi, p_Dz, -1.0)) > 1e-3
    r0, _, _ = _steady(config, _saturating())
    assert r < r0


def test_lateral_load_transfer_needs_the_vehicle_geometry(config):
    sim, _ = _simulator(config, lambda t: 0.01 * np.ones_like(t), t_end=0.5)
    sim.car = replace(sim.car, track_width=None)
    with pytest.raises(ConfigError, match="track_width"):
        sim.simulate(THETA, _saturating(lateral_load_transfer=[0.5, -0.1]))


@pytest.mark.parametrize("tyre", ["linear", "magic_formula"])
def test_compliance_steer_turns_the_wheels_by_minus_K_a_y(config, tyre):
    """Steady yaw-rate gain G without compliance: the wheels yield by kappa F_f (kappa = K / F_zf,
    K in rad per g) and at steady cornering F_f = F_zf a_y / g, so delta_f = delta - K v r / g and
    the steady yaw rate is G delta / (1 + G K v) (rad/(m/s^2) from deg/g); to 1e-6 relative on
    the exact (linear) path. On the Magic Formula (RK4) the steady front force is
    m v r l_r / (L cos delta_f cos beta): the yaw rate is the uncompliant gain's at that wheel
    angle, to 1e-6. Removing the term gives G delta (off by 4 % at K = 1 deg/g), a flipped sign
    G delta / (1 - G K v)."""
    K = 1.0
    base = ModelStructure() if tyre == "linear" else _saturating()
    comp = effect("compliance_steer").augment(base, [K])
    r0, _, delta = _steady(config, base, delta_deg=1.0)
    r, beta, _ = _steady(config, comp, delta_deg=1.0)
    if tyre == "magic_formula":  # non-linear: the gain at the smaller actual steer angle
        p = VehicleParameters.from_settings(Settings.from_config(config), mu=THETA[0], l_f=THETA[2], v_c=V)
        d_f = delta
        for _ in range(5):  # delta_f = delta - kappa F_f(delta_f): a contraction (kappa dF/d delta ~ 0.01)
            d_f = delta - np.deg2rad(K) / p.F_fz * p.m * V * r * p.l_r / (p.wheelbase * np.cos(d_f) * np.cos(beta))
        r_eff, _, _ = _steady(config, base, delta_deg=np.rad2deg(d_f))
        assert abs(r / r_eff - 1) < 1e-6
        assert r < r0 * (1 - 0.02)
        return
    G, k = r0 / delta, np.deg2rad(K) / 9.81
    assert abs(r / (G * delta / (1 + G * k * V)) - 1) < 1e-6
    assert abs(r / r0 - 1) > 0.02 and abs(r / (G * delta / (1 - G * k * V)) - 1) > 0.02


def test_compliance_steer_is_a_softer_front_axle_in_transients_too(config):
    """The wheels yield to the front force, not to the yaw rate: on the linear tyre the model with
    K = 1 deg/g is the LST with c_f / (1 + K c_Sf C mu), built here by hand and integrated by the
    matrix exponential (first-order hold), on a 0.5 Hz slalom: equal to 1e-9 of the yaw rate's
    range. A wheel angle driven by v psi_dot (the steady a_y) instead, the same at steady state,
    misses it in the transient by more than 1 % of that range."""
    K, d = 1.0, np.deg2rad(2.0)
    sim, t = _simulator(config, lambda t: d * np.sin(2 * np.pi * 0.5 * t) * (t < 3.0), t_end=5.0)
    x = sim.simulate(THETA, effect("compliance_steer").augment(ModelStructure(), [K]))[:, 0]
    p = VehicleParameters.from_settings(Settings.from_config(config), mu=THETA[0], l_f=THETA[2], v_c=V)
    k = np.deg2rad(K)

    def response(c_f, feedback=0.0):
        A = np.zeros((4, 4))
        A[0, 1], A[3, 0] = 1.0, V
        A[1, 1] = -(c_f * p.l_f**2 + p.c_r * p.l_r**2) / (p.I_z * V)
        A[1, 2] = A[2, 1] = (p.c_r * p.l_r - c_f * p.l_f)
        A[1, 2] /= p.I_z
        A[2, 1] = A[2, 1] / (p.m * V**2) - 1.0
        A[2, 2] = -(c_f + p.c_r) / (p.m * V)
        b = np.array([0.0, p.l_f * c_f / p.I_z, c_f / (p.m * V), 0.0])
        A[:, 1] -= b * feedback  # delta - feedback psi_dot
        return _foh_response(A, b, d * np.sin(2 * np.pi * 0.5 * t) * (t < 3.0))

    span = np.ptp(x[1])
    soft = response(p.c_f / (1.0 + k * p.c_Sf * p.C * THETA[0]))
    assert np.abs(x[1] - soft[1]).max() < 1e-9 * span
    by_yaw_rate = response(p.c_f, feedback=k / 9.81 * V)
    assert np.abs(x[1] - by_yaw_rate[1]).max() > 1e-2 * span


@pytest.mark.parametrize("tyre, relaxed", [("magic_formula", False), ("magic_formula", True), ("linear", False)])
def test_compliant_front_wheels_carry_the_force_they_yield_to(config, tyre, relaxed, monkeypatch):
    """The loop F_f = F(alpha_f - kappa F_f), kappa = K / F_zf, on the Magic Formula (Newton) and
    on the linear tyre at the axle's current load (closed form): at random states with lateral
    load transfer (and relaxing tyres, whose force comes from the lagged slip and moves the slip's
    target by -kappa F_f), the right-hand side's front force and wheel angle satisfy it to 1e-9
    of the force; the wheel angle is delta - kappa F_f, and without the compliance the force
    differs by more than 1 %."""
    from uqdrive.vehicle import track_extended
    from uqdrive.vehicle.track_extended import ExtendedSingleTrackRHS

    rng = np.random.default_rng(5)
    n, K = 40, 2.0
    fields = dict(lateral_load_transfer=[0.6, -0.3], compliance_steer=[K], **({"tyre_relaxation": [0.5]} if relaxed else {}))
    s = _saturating(**fields) if tyre == "magic_formula" else ModelStructure()
    if tyre == "linear":
        for name, values in fields.items():
            s = effect(name).augment(s, values)
    p = VehicleParameters.from_settings(Settings.from_config(config), mu=np.full(n, 1.0), l_f=np.full(n, 1.55), v_c=V)
    rhs = ExtendedSingleTrackRHS(p, s, 0.97, np.deg2rad([2.0, 4.0, 6.0]), np.zeros((3, n)), True, np.zeros(n), H, T_W)
    x = np.vstack([rng.normal(0, 0.2, n), rng.normal(0, 0.3, n), rng.normal(0, 0.03, n), rng.normal(0, 1, n),
                   rng.normal(0, 0.05, (2, n))])[: rhs.n_states]
    monkeypatch.setattr(track_extended, "LOAD_NEWTON_STEPS", 12)  # the loads-forces loop to rounding
    q, delta_f, F = rhs._forces(x, 1, V, 0.0)
    tyres = F[0] * (np.cos(delta_f) if tyre == "magic_formula" else 1.0) + F[1]
    kappa = np.deg2rad(K) / p.F_fz
    np.testing.assert_allclose(delta_f, np.deg2rad(4.0) - kappa * F[0], rtol=0, atol=1e-12)
    q0, _ = rhs.steady_slip(x, 1)
    slip = x[4] if relaxed else q0[0] - kappa * F[0]
    np.testing.assert_allclose(F[0], rhs.tyre_forces(np.stack([slip, slip]), tyres, x[2])[0], rtol=0, atol=1e-9 * np.abs(F[0]).max())
    np.testing.assert_allclose(q[0], q0[0] - kappa * F[0], rtol=0, atol=1e-12)
    from dataclasses import replace

    stiff = ExtendedSingleTrackRHS(p, replace(s, compliance_steer=0.0), 0.97, np.deg2rad([2.0, 4.0, 6.0]), np.zeros((3, n)), True, np.zeros(n), H, T_W)
    q_stiff, _, F_stiff = stiff._forces(x, 1, V, 0.0)
    changed = np.abs(q_stiff[0] - q[0]) if relaxed else np.abs(F_stiff[0] - F[0])
    assert changed.max() > 1e-2 * (np.abs(q[0]).max() if relaxed else np.abs(F[0]).max())


def test_roll_steer_turns_the_wheels_by_minus_K_a_y_after_the_roll(config):
    """Roll steer K (deg/g at the base mass) through a roll mode (f, zeta): at steady cornering the
    wheels turn by -k_N T, k_N = K / (m_base g) per newton of the tyres' force T = m v r (the roll
    moment over the roll stiffness, a constant of the car), so on the linear tyre the steady yaw
    rate is G delta / (1 + G k_N m v), to 1e-9 (the uncompliant gain G; removed: G delta, 13 % off
    at K = 1; flipped: G delta / (1 - G k_N m v); per g of each realisation's own mass, k_N m =
    K / g, misses by more than 1e-3 with this car's load). In a 0.5 Hz slalom the model equals the 6-state linear system with the steer
    angle eps'' = omega^2 (k_N (F_f + F_r) - eps) - 2 zeta omega eps', delta_f = delta - eps
    (matrix exponential, the input linear between samples) to 1e-5 of the yaw rate's range (RK4:
    2e-6); with another damping ratio (1.2 for 0.6), a four times faster mode or the compliance
    steer's instant yielding it misses by more than 1 % (2.4, 2.2, 3.5 %)."""
    from dataclasses import replace

    K, f, zeta = 1.0, 1.5, 0.6
    base = ModelStructure()
    d = np.deg2rad(3.0)
    sim, t = _simulator(config, lambda t: d * np.sin(2 * np.pi * 0.5 * t) * (t < 3.0), t_end=5.0)
    # the first realisation's load (the LST's own response does not depend on the mass: c and I_z scale with it)
    p = replace(VehicleParameters.from_settings(Settings.from_config(config), mu=THETA[0], l_f=THETA[2], v_c=V), m_load=float(sim.m_load[0]))
    r0, _, delta = _steady(config, base, delta_deg=1.0)
    r, _, _ = _steady(config, effect("roll_steer").augment(base, [K, f, zeta]), delta_deg=1.0)
    G, k = r0 / delta, np.deg2rad(K) / (p.m_base * p.g)  # rad per N
    assert abs(r / (G * delta / (1 + G * k * p.m * V)) - 1) < 1e-9
    assert abs(r / r0 - 1) > 0.1 and abs(r / (G * delta / (1 - G * k * p.m * V)) - 1) > 0.1
    assert abs(r / (G * delta / (1 + G * np.deg2rad(K) / p.g * V)) - 1) > 1e-3

    x = sim.simulate(THETA, effect("roll_steer").augment(base, [K, f, zeta]))[:, 0]

    def response(f, zeta):
        w = 2 * np.pi * f
        A = np.zeros((6, 6))  # psi, r, beta, y, eps, eps'
        F_f = np.array([0.0, -p.l_f / V, -1.0, 0.0, -1.0, 0.0]) * p.c_f  # c_f (delta - eps - beta - l_f r / v)
        F_r = np.array([0.0, p.l_r / V, -1.0, 0.0, 0.0, 0.0]) * p.c_r
        A[0, 1], A[3, 0], A[4, 5] = 1.0, V, 1.0
        A[1] = (p.l_f * F_f - p.l_r * F_r) / p.I_z
        A[2] = (F_f + F_r) / (p.m * V)
        A[2, 1] -= 1.0
        A[5] = w * w * k * (F_f + F_r)
        A[5, 4] -= w * w
        A[5, 5] -= 2 * zeta * w
        b = np.array([0.0, p.l_f * p.c_f / p.I_z, p.c_f / (p.m * V), 0.0, 0.0, w * w * k * p.c_f])
        return _foh_response(A, b, d * np.sin(2 * np.pi * 0.5 * t) * (t < 3.0))

    span = np.ptp(x[1])
    assert np.abs(x[1] - response(f, zeta)[1]).max() < 1e-5 * span
    assert np.abs(x[1] - response(f, 1.2)[1]).max() > 1e-2 * span
    assert np.abs(x[1] - response(4 * f, zeta)[1]).max() > 1e-2 * span
    instant = sim.simulate(THETA, effect("compliance_steer").augment(base, [K]))[:, 0]
    assert np.abs(x[1] - instant[1]).max() > 1e-2 * span


def test_tyre_relaxation_is_a_first_order_lag_of_the_slip_angles(config):
    """A 0.2 deg steer step with linear tyres: the model equals the 6-state linear system with
    the lagged slips alpha' = (alpha_ss - alpha) v / sigma and forces c alpha (solved here by
    the matrix exponential) to 2e-3 of the yaw rate's range (the model keeps the arctan slip
    kinematics: ~1e-4 at this angle); without the lag the same system misses it by > 5 times
    that, and sigma <= 0 is no lag."""
    from scipy.linalg import expm

    sigma, d = 1.0, np.deg2rad(0.2)
    sim, t = _simulator(config, lambda t: d * (t >= 0.5), t_end=3.0)
    lagged = sim.simulate(THETA, effect("tyre_relaxation").augment(ModelStructure(), [sigma]))[:, 0]
    p = VehicleParameters.from_settings(Settings.from_config(config), mu=THETA[0], l_f=THETA[2], v_c=V)

    def linear_response(s):
        A = np.zeros((6, 6))  # psi, r, beta, y, alpha_f, alpha_r
        A[0, 1] = 1.0
        A[1, 4], A[1, 5] = p.l_f * p.c_f / p.I_z, -p.l_r * p.c_r / p.I_z
        A[2, 4], A[2, 5], A[2, 1] = p.c_f / (p.m * V), p.c_r / (p.m * V), -1.0
        A[3, 0] = V
        A[4, 2], A[4, 1], A[4, 4] = -V / s, -p.l_f / s, -V / s  # (delta - beta - l_f r / v - alpha_f) v / s
        A[5, 2], A[5, 1], A[5, 5] = -V / s, p.l_r / s, -V / s
        b = np.zeros(6)
        b[4] = V / s * d
        x, out = np.zeros(6), []
        # the step arrives as a ramp over the sample before t = 0.5 (linear interpolation)
        for k, tk in enumerate(t):
            out.append(x.copy())
            if k + 1 < t.size:
                u0, u1 = float(t[k] >= 0.5), float(t[k + 1] >= 0.5)
                M = np.zeros((8, 8))  # Van Loan: x' = A x + b (u0 w1 + (u1 - u0) w2), w1 = 1, w2 = tau / DT
                M[:6, :6], M[:6, 6], M[:6, 7], M[7, 6] = A, b * u0, b * (u1 - u0), 1.0 / DT
                x = (expm(M * DT) @ np.concatenate([x, [1.0, 0.0]]))[:6] if u1 else x
        return np.array(out).T

    ref = linear_response(sigma)
    scale = np.abs(ref[1]).max()
    assert np.abs(lagged[1] - ref[1]).max() < 2e-3 * scale
    assert np.abs(linear_response(1e-3)[1] - ref[1]).max() > 1e-2 * scale  # the lag matters at this size


def test_zero_sized_chassis_effects_leave_the_model_bit_identical(config):
    """h = 0, p_Dz = 0, K = 0 (compliance and roll steer): the thesis' right-hand side, to the last bit."""
    sim, _ = _simulator(config, lambda t: 0.05 * np.sin(t), t_end=2.0)
    for base in (ModelStructure(), _saturating()):
        ref = sim.simulate(THETA, base)
        for name, values in (("longitudinal_load_transfer", [0.0]), ("lateral_load_transfer", [0.6, 0.0]), ("compliance_steer", [0.0]),
                             ("roll_steer", [0.0, 2.0, 0.6])):
            assert np.array_equal(sim.simulate(THETA, effect(name).augment(base, values)), ref), name


def test_chassis_loads_stay_physical_when_a_realisation_spins(config):
    """A spinning realisation (psi_dot 1 rad/s, beta 0.5 rad) with the strongest transfer the
    search allows (h = 1.5 m, p_Dz = -1, chi_f = 1): the inner wheels lift and carry nothing,
    no axle's effective load turns negative (a negative peak reverses the tyre force and the
    integration diverges, stopping a discover fit), and a 10 deg step stays finite."""
    from uqdrive.vehicle.track_extended import ExtendedSingleTrackRHS

    s = _saturating(longitudinal_load_transfer=[1.5], lateral_load_transfer=[1.0, -1.0])
    p = VehicleParameters.from_settings(Settings.from_config(config), mu=1.0, l_f=1.55, v_c=V)
    rhs = ExtendedSingleTrackRHS(p, s, 0.97, np.zeros(3), np.zeros((3, 1)), True, np.zeros(1), H, T_W)
    P = rhs.axle_loads(np.array([p.m * V * 1.0]), np.array([0.5]))  # the tyres' force of v psi_dot = 19 m/s^2
    assert np.all(np.isfinite(P)) and np.all(P >= 0.0)
    sim, _ = _simulator(config, lambda t: np.deg2rad(10.0) * (t >= 0.2), t_end=4.0)
    assert np.all(np.isfinite(sim.simulate([1.0, 0.0, 1.55, 0.0, 0.0, 0.0], s)))


@pytest.mark.parametrize("tyre", ["linear", "magic_formula"])
def test_the_loads_follow_the_force_the_tyres_carry(config, tyre, monkeypatch):
    """Load transfer comes from the tyres' own lateral force T (roll moment h T / t, a_x from
    a_y = (T + F_w) / m), which depends on the loads: at random states with lateral and
    longitudinal transfer and wind, the converged loop's forces are the forces of the loads
    their own sum makes (1e-9 of the force). The steady guess T = m v psi_dot cos(beta) - F_w
    (the loop left out) misses by more than 1e-3, and on a 5 deg, 0.6 Hz slalom the default two
    Newton steps keep the yaw rate within 1e-4 of its range of the converged loop."""
    from uqdrive.vehicle import track_extended
    from uqdrive.vehicle.track_extended import LOAD_NEWTON_STEPS, ExtendedSingleTrackRHS

    rng = np.random.default_rng(11)
    n = 60
    fields = dict(lateral_load_transfer=[0.6, -0.4], longitudinal_load_transfer=[0.55])
    s = _saturating(**fields) if tyre == "magic_formula" else ModelStructure()
    if tyre == "linear":
        for name, values in fields.items():
            s = effect(name).augment(s, values)
    p = VehicleParameters.from_settings(Settings.from_config(config), mu=np.full(n, 1.0), l_f=np.full(n, 1.55), v_c=V)
    F_w = rng.uniform(-300.0, 300.0, (3, n))
    rhs = ExtendedSingleTrackRHS(p, s, 0.97, np.deg2rad([2.0, 4.0, 6.0]), F_w, True, np.zeros(n), H, T_W)
    x = np.vstack([rng.normal(0, 0.2, n), rng.normal(0, 0.2, n), rng.normal(0, 0.02, n), rng.normal(0, 1, n)])
    front = (lambda F, d: F * np.cos(d)) if tyre == "magic_formula" else (lambda F, d: F)  # noqa: E731

    def sum_and_forces(steps):
        monkeypatch.setattr(track_extended, "LOAD_NEWTON_STEPS", steps)
        q, d, F = rhs._forces(x, 1, V, 0.0)
        return front(F[0], d) + F[1], q, F

    tyres, q, F = sum_and_forces(12)
    np.testing.assert_allclose(F, rhs.tyre_forces(q, tyres, x[2], F_w=F_w[1]), rtol=0, atol=1e-9 * np.abs(F).max())
    assert np.abs(sum_and_forces(0)[2] - F).max() > 1e-3 * np.abs(F).max()

    sim, _ = _simulator(config, lambda t: np.deg2rad(5.0) * np.sin(2 * np.pi * 0.6 * t) * (t > 0.3), t_end=4.0)
    theta = [1.0, 0.0, 1.55, 0.0, 0.0, 0.0]
    monkeypatch.setattr(track_extended, "LOAD_NEWTON_STEPS", 12)
    converged = sim.simulate(theta, s)[1, 0]
    monkeypatch.setattr(track_extended, "LOAD_NEWTON_STEPS", LOAD_NEWTON_STEPS)
    error = np.abs(sim.simulate(theta, s)[1, 0] - converged).max()
    assert 0 < error < 1e-4 * np.ptp(converged)  # not 0: the setting reaches the simulator


def test_chassis_a_y_is_the_specific_force_of_the_lagged_tyres_and_the_wind(config):
    """a_y of the chassis model, (F_f cos delta + F_r + F_w) / m, against the same force read off
    the right-hand side's beta_dot, (beta_dot + psi_dot) v / cos(beta) (no bank), at random states
    with relaxing tyres (their lagged slip angles away from the steady ones), load transfer and
    wind: equal to rounding (1e-9 m/s^2). Without the wind, the cos delta, or with the steady slip
    angles in place of the lagged ones the two differ by 1e-2 m/s^2 or more."""
    from uqdrive.vehicle.track_extended import ExtendedSingleTrackRHS

    rng = np.random.default_rng(3)
    n = 50
    s = _saturating(lateral_load_transfer=[0.6, -0.3], tyre_relaxation=[0.5])
    p = VehicleParameters.from_settings(Settings.from_config(config), mu=np.full(n, 1.0), l_f=np.full(n, 1.55), v_c=V)
    F_w = rng.uniform(-800.0, 800.0, (3, n))
    rhs = ExtendedSingleTrackRHS(p, s, 0.97, np.deg2rad([2.0, 4.0, 6.0]), F_w, True, np.zeros(n), H, T_W)
    x = np.vstack([rng.normal(0, 0.2, n), rng.normal(0, 0.3, n), rng.normal(0, 0.03, n), rng.normal(0, 1, n),
                   rng.normal(0, 0.05, (2, n))])
    out = np.empty_like(x)
    rhs(x, 1, out)
    from_beta_dot = (out[2] + x[1]) * V / np.cos(x[2])
    a_y = rhs.lateral_acceleration(x, 1)
    np.testing.assert_allclose(a_y, from_beta_dot, rtol=0, atol=1e-9)
    q_steady, _ = rhs.steady_slip(x, 1)
    tyres = p.m * a_y - F_w[1]
    assert np.abs(rhs.tyre_forces(q_steady, tyres, x[2]) - rhs.tyre_forces(x[4:6], tyres, x[2])).sum(0).max() / p.m > 1e-2


def test_a_chassis_model_records_a_y_beside_its_states(config):
    """On a file with a_y, a chassis candidate (tyre relaxation) is simulated with it: the
    states equal those of the four-channel simulation bit for bit, and a_y follows the lateral
    kinematics, v (beta_dot + psi_dot) / cos(beta) from the recorded states (central
    differences on the 10 ms grid: agreement to 1e-3 of a_y's range)."""
    from uqdrive.inference.discrepancy.effectset import testable
    from uqdrive.vehicle.channels import CHANNELS

    s = _saturating(tyre_relaxation=[0.5])
    delta = lambda t: np.deg2rad(3.0) * np.sin(2 * np.pi * 0.5 * t)  # noqa: E731
    sim4, t = _simulator(config, delta, t_end=3.0)
    cfg = {**config, "vehicle": {**config["vehicle"], "cg_height": H, "track_width": T_W}}
    sim5 = AugmentedSimulator.drawn(Settings.from_config(cfg), t, delta(t), V, 2, np.random.default_rng(0), channels=CHANNELS)
    sim5.sigma = 0.0
    x4, x5 = sim4.simulate(THETA, s), sim5.simulate(THETA, s)
    assert x5.shape[0] == 5 and np.array_equal(x5[:4], x4)
    psi_dot, beta, a_y = x5[1, 0], x5[2, 0], x5[4, 0]
    kinematic = V * (np.gradient(beta, DT) + psi_dot) / np.cos(beta)
    assert np.abs(a_y - kinematic)[2:-2].max() < 1e-3 * np.ptp(a_y)
    keep, untestable = testable(["tyre_relaxation", "lateral_load_transfer"], CHANNELS)
    assert keep == ["tyre_relaxation", "lateral_load_transfer"] and untestable == []


def _braking(t, v0=80.0 / 3.6, v1=50.0 / 3.6, t0=2.0, t1=5.0):
    """A speed profile (m/s) that brakes linearly from v0 to v1 between t0 and t1 (-2.8 m/s^2)."""
    return np.interp(t, [0.0, t0, t1, t[-1]], [v0, v0, v1, v1])


def test_longitudinal_load_transfer_follows_the_brake_force_along_a_speed_profile(config):
    """Along a measured speed the body's acceleration is a_x = v' cos(beta) - tan(beta) (a_y -
    v' sin(beta)) (Rajamani eq. (2.27)), a_y the tyres' force over m, so braking loads the front
    axle by m |v'| h / L. On the linear tyre (the LST (5.4): small angles, slope mu F_z B C) the
    loads-forces loop is linear; the right-hand side at one state equals the hand-solved loop and
    the balance on its loads at the profile's speed, with beta' gaining
    -(v' / v) beta and y' = v psi: to rounding (1e-12). Fails with the v' term of a_x removed or
    its sign flipped, with the held speed in place of v(t), or without the v' term of beta'."""
    from uqdrive.vehicle.track_extended import ExtendedSingleTrackRHS

    h, v, v_dot = 0.55, 16.0, -3.0  # v away from the held speed V
    p = VehicleParameters.from_settings(Settings.from_config(config), mu=np.array([0.9]), l_f=np.array([1.4]), v_c=V)  # one realisation
    s = effect("longitudinal_load_transfer").augment(ModelStructure(), [h])
    delta = np.deg2rad(3.0)
    rhs = ExtendedSingleTrackRHS(p, s, 0.97, np.full(3, delta), np.zeros((3, 1)), True, np.zeros(1),
                                 speed_half=(np.array([V, v, V]), np.array([0.0, v_dot, 0.0])))
    psi, r, beta = 0.1, 0.3, -0.02
    out = np.empty((4, 1))
    rhs(np.array([[psi], [r], [beta], [0.0]]), 1, out)

    q_f, q_r = delta - beta - p.l_f * r / v, p.l_r * r / v - beta
    k_f, k_r = p.mu * p.c_Sf * p.C * q_f, p.mu * p.c_Sr * p.C * q_r  # force per newton of axle load
    # the loop T = k_f F_zf(T) + k_r F_zr(T) with a_x = v' / cos(beta) - tan(beta) T / m is linear in T
    arm = (k_r - k_f) * p.m * h / p.wheelbase
    T = (k_f * p.F_fz + k_r * p.F_rz + arm * v_dot / np.cos(beta)) / (1.0 + arm * np.tan(beta) / p.m)
    a_x = v_dot * np.cos(beta) - np.tan(beta) * (T / p.m - v_dot * np.sin(beta))
    F_zf, F_zr = p.m * (p.g * p.l_r - a_x * h) / p.wheelbase, p.m * (p.g * p.l_f + a_x * h) / p.wheelbase
    assert F_zf > p.F_fz + 0.8 * p.m * 3.0 * h / p.wheelbase  # braking loads the front axle
    F_f, F_r = k_f * F_zf, k_r * F_zr
    expected = [r, (p.l_f * F_f - p.l_r * F_r) / p.I_z, (F_f + F_r) / (p.m * v) - r - v_dot / v * beta, v * psi]
    assert out[:, 0] == pytest.approx(np.concatenate([np.atleast_1d(e) for e in expected]), rel=1e-12, abs=1e-15)


def test_a_vanishing_chassis_effect_on_the_linear_tyre_is_the_lst(config):
    """A chassis effect adds its own term and keeps the baseline's kinematics: with a vanishing
    transfer (h = 1e-12 m routes the simulation through the chassis model's RK4) the linear-tyre
    model equals the LST, thesis (5.4), at held speed (exact discretisation) and along a braking
    profile (uqdrive.vehicle.track_rk4.LinearTrackRHS), to the RK4's accuracy (1e-5 of each
    state's range: 10 ms steps over the ramp's corners, measured 1.4e-6) on a step steer whose heading turns by ~1 rad (where v sin(psi) would be off by
    ~15 % of y). With ``lateral_kinematics`` (course_exact) y follows v sin(psi + k beta) instead."""
    t = np.arange(801) * DT
    delta = np.deg2rad(3.0) * np.clip(t - 0.5, 0.0, 1.0)
    cfg = {**config, "vehicle": {**config["vehicle"], "cg_height": H, "track_width": T_W}}
    for speed in (None, _braking(t)):
        v_c = V if speed is None else float(np.mean(speed))
        sim = AugmentedSimulator.drawn(Settings.from_config(cfg), t, delta, v_c, 2, np.random.default_rng(0), speed=speed)
        sim.sigma = 0.0
        lst = sim.simulate(THETA, ModelStructure())
        chassis = sim.simulate(THETA, effect("longitudinal_load_transfer").augment(ModelStructure(), [1e-12]))
        span = np.ptp(lst, axis=-1, keepdims=True)
        assert np.abs(lst[0, 0]).max() > 0.8  # the heading turns: the sine would show
        assert np.all(np.abs(chassis - lst) <= 1e-5 * span), np.abs(chassis - lst).max(axis=(1, 2))
        course = effect("lateral_kinematics").augment(ModelStructure(), [1.0])
        exact = sim.simulate(THETA, course)
        both = sim.simulate(THETA, effect("longitudinal_load_transfer").augment(course, [1e-12]))
        assert np.all(np.abs(both - exact) <= 1e-5 * span) and np.abs(both[3] - chassis[3]).max() > 0.05 * span[3].max()


def test_the_chassis_model_along_a_speed_profile_is_the_single_track_model_when_its_terms_vanish(config):
    """With a vanishing transfer (h = 1e-12 m routes the simulation through the chassis model) the
    Magic-Formula chassis model braking in a turn gives the states of the single-track model along
    the same speed profile (uqdrive.vehicle.dynamics.rhs.SingleTrackRHS) to 1e-9 of each state's range;
    with h = 0.55 m the braking loads the front axle and the yaw rate rises while the car brakes
    (more front force: oversteer), above 1 % of its peak."""
    t = np.arange(801) * DT
    delta = np.deg2rad(3.0) * np.clip(t - 0.5, 0.0, 1.0)
    cfg = {**config, "vehicle": {**config["vehicle"], "cg_height": H, "track_width": T_W}}
    speed = _braking(t)
    sim = AugmentedSimulator.drawn(Settings.from_config(cfg), t, delta, float(np.mean(speed)), 2, np.random.default_rng(0), speed=speed)
    sim.sigma = 0.0
    plain = sim.simulate(THETA, _saturating())
    vanishing = sim.simulate(THETA, _saturating(longitudinal_load_transfer=[1e-12]))
    loaded = sim.simulate(THETA, _saturating(longitudinal_load_transfer=[0.55]))
    span = np.ptp(plain, axis=-1, keepdims=True)
    assert np.all(np.abs(vanishing - plain) <= 1e-9 * span)
    braking = (t >= 2.5) & (t <= 5.0)
    rise = loaded[1, 0, braking] - plain[1, 0, braking]
    assert rise.mean() > 0.01 * np.abs(plain[1, 0]).max()
    # before the brakes only the small steady a_x = -v r sin(beta) acts
    before = t < 2.0
    assert np.abs(loaded[1, 0, before] - plain[1, 0, before]).max() < 0.2 * rise.mean()


def test_every_chassis_candidate_is_testable_on_a_file_whose_speed_changes():
    from uqdrive.inference.discrepancy.effectset import testable
    from uqdrive.vehicle.channels import CHANNELS

    names = ["longitudinal_load_transfer", "lateral_load_transfer", "compliance_steer", "tyre_relaxation"]
    assert testable(names, CHANNELS) == (names, [])


def test_half_angle_sine_and_cosine_are_numpys_to_rounding():
    """The chassis right-hand side takes sin and cos from the tangent of the half angle (NumPy
    vectorises tan, not the float64 sine): within 4 eps of np.sin and np.cos on |angle| < pi (tan
    and the three operations after it round once each, and cos = (1 - t^2) / (1 + t^2) loses no
    more near pi / 2); a course turned beyond 3 rad (or NaN) takes np.sin itself, where the half
    angle's tangent grows without bound, each realisation by its own angle: the sines of a batch
    are those of its parts computed apart."""
    from uqdrive.vehicle.axle_loads import course_sine as _sine, half_angle_sin_cos

    rng = np.random.default_rng(5)
    angle = np.concatenate([rng.uniform(-np.pi + 1e-6, np.pi - 1e-6, 20000), rng.normal(0.0, 0.02, 2000)])
    s, c = half_angle_sin_cos(angle)
    eps = np.finfo(float).eps
    assert np.abs(s - np.sin(angle)).max() <= 4 * eps and np.abs(c - np.cos(angle)).max() <= 4 * eps
    near = angle[-10:]  # within 3 rad
    assert np.array_equal(_sine(near), half_angle_sin_cos(near)[0])
    far = np.array([0.1, 7.5, -12.0, np.nan])
    np.testing.assert_array_equal(_sine(far), [half_angle_sin_cos(0.1)[0], np.sin(7.5), np.sin(-12.0), np.nan])
    batch = np.concatenate([angle[:7], far])
    np.testing.assert_array_equal(_sine(batch), np.concatenate([_sine(angle[:7]), _sine(far)]))
    assert not np.array_equal(np.sin(angle[:7]), half_angle_sin_cos(angle[:7])[0])  # NumPy's sine for all would differ

"""The chassis effects of the hidden-effect benchmark's reality (uqdrive.studies.hidden.chassis):
each against a response derived here on its own (a linear state-space model or the steady
cornering balance), so that removing the reality's term or flipping its sign fails; and the
benchmark's chassis cases, which leave every other case's seed where it was."""

import copy

import numpy as np
import pytest
from scipy.signal import lsim

from uqdrive.studies.hidden_effects import CHASSIS_EFFECTS, HiddenEffectCase, benchmark_cases, simulate_channels, wind_kle
from uqdrive.studies.manoeuvres import steering_command
from uqdrive._errors import ConfigError

H, TRACK = 0.55, 1.6  # m, cg height and track width of the tests' car
DRAWS = {"mu": np.array([1.0, 0.85, 1.1]), "m_load": np.array([100.0, 40.0, 160.0]), "l_f": np.array([1.55, 1.40, 1.70])}


@pytest.fixture
def calm(config):
    """No wind (the response is the steering's alone), 2.5 s, the car's cg height and track."""
    c = copy.deepcopy(config)
    c["wind"]["sigma"] = 0.0
    c["uncertainty"]["F_w_mean"] = {"low": 0.0, "high": 0.0}
    c["time"]["t_end"] = 2.5
    c["vehicle"].update(cg_height=H, track_width=TRACK)
    return c


def run(cfg, case):
    """Clean states (4, n, T) and times of ``case`` at the DRAWS (no wind)."""
    kle = wind_kle(cfg)
    draws = dict(DRAWS, F_w_mean=np.zeros(3), xi_wind=np.zeros((3, kle.n_modes)))
    t, _, x, _, _ = simulate_channels(cfg, case, draws, kle)
    return t, x


def car(cfg):
    """Per-realisation m, I_z, l_f, l_r, static axle loads and linear cornering stiffnesses
    c = B C mu F_z (the Magic Formula's slope at zero slip), thesis (5.4)."""
    veh = cfg["vehicle"]
    m = veh["m_base"] + DRAWS["m_load"]
    l_f = DRAWS["l_f"]
    l_r = veh["wheelbase"] - l_f
    F_fz, F_rz = m * veh["g"] * l_r / veh["wheelbase"], m * veh["g"] * l_f / veh["wheelbase"]
    C = cfg["tyre"]["C"]
    return dict(m=m, I_z=m * veh["J0"], l_f=l_f, l_r=l_r, F_fz=F_fz, F_rz=F_rz, L=veh["wheelbase"], g=veh["g"],
                v=veh["speed_kmh"] / 3.6, c_f=F_fz * veh["c_Sf"] * C * DRAWS["mu"], c_r=F_rz * veh["c_Sr"] * C * DRAWS["mu"])


def linear_response(cfg, case, c_f_of, sigma=0.0):
    """psi_dot and beta (n, T) of the linear single-track model, thesis (5.4), by scipy's lsim on a
    1 ms grid: front stiffness ``c_f_of(k, p)`` of realisation k, and with sigma > 0 both slip
    angles lagged, alpha' = (alpha_ss - alpha) v / sigma (two states)."""
    p = car(cfg)
    v = p["v"]
    t_fine = np.arange(0.0, cfg["time"]["t_end"] + 5e-4, 1e-3)
    delta = steering_command(case.manoeuvre, t_fine, dict(case.manoeuvre_params))
    r_out, b_out = [], []
    for k in range(3):
        m, I_z, l_f, l_r, c_f, c_r = p["m"][k], p["I_z"][k], p["l_f"][k], p["l_r"][k], c_f_of(k, p), p["c_r"][k]
        # states [r, beta] (+ [alpha_f, alpha_r]); slip kinematics alpha_f = delta - beta - l_f r / v, alpha_r = l_r r / v - beta
        slip = np.array([[-l_f / v, -1.0], [l_r / v, -1.0]])  # d alpha_ss / d [r, beta]
        if sigma == 0.0:
            Fx = np.diag([c_f, c_r]) @ slip  # axle forces per state
            A = np.array([[l_f, -l_r], [1.0, 1.0]]) @ Fx / np.array([[I_z], [m * v]]) - np.array([[0.0, 0.0], [1.0, 0.0]])
            B = np.array([[l_f * c_f / I_z], [c_f / (m * v)]])
        else:
            A = np.zeros((4, 4))
            A[0, 2:], A[1, 2:] = np.array([l_f * c_f, -l_r * c_r]) / I_z, np.array([c_f, c_r]) / (m * v)
            A[1, 0] = -1.0
            A[2:, :2] = slip * (v / sigma)
            A[2:, 2:] = -np.eye(2) * (v / sigma)
            B = np.array([[0.0], [0.0], [v / sigma], [0.0]])
        _, out, _ = lsim((A, B, np.eye(len(A)), np.zeros((len(A), 1))), delta, t_fine)
        r_out.append(out[:, 0])
        b_out.append(out[:, 1])
    idx = np.rint(np.arange(round(cfg["time"]["t_end"] / cfg["time"]["dt"]) + 1) * cfg["time"]["dt"] / 1e-3).astype(int)
    return np.array(r_out)[:, idx], np.array(b_out)[:, idx]


def test_chassis_cases_join_at_the_end_and_move_no_seed(config):
    """Seeds are root + 101 + the position in the tables' order: the 34 cases of the single,
    combined and held_null tables keep theirs whether or not the chassis cases are included, and
    the chassis cases (included only when discover may name their chassis effects) follow."""
    root = int(config["seed"])
    plain = benchmark_cases(config, samples=20)
    assert [c.seed for c in plain[:-1]] == list(range(root + 101, root + 101 + 34)) and plain[-1].seed == root
    assert not any(e in CHASSIS_EFFECTS for c in plain for e, _, _ in c.effects)
    chassis_config = copy.deepcopy(config)
    chassis_config["discrepancy"]["candidates"] = list(config["discrepancy"]["candidates"]) + list(CHASSIS_EFFECTS)
    full = benchmark_cases(chassis_config, samples=20)
    assert full[:34] == plain[:-1] and full[-1] == plain[-1]
    added = full[34:-1]
    assert [c.seed for c in added] == list(range(root + 135, root + 135 + len(added)))
    assert {e for c in added for e, _, _ in c.effects} >= set(CHASSIS_EFFECTS)
    assert sum(len(c.effects) == 1 for c in added) >= 3 and sum(len(c.effects) >= 2 for c in added) >= 2
    assert any({e for e, _, _ in c.effects} == {"lateral_kinematics", "lateral_load_transfer"} for c in added)
    braking = [c for c in added if c.speed]  # the transfer alone, from the brake force that follows the speed
    assert [c.name for c in added[-2:]] == ["roll_steer_04", "combined_roll_relaxation"]  # the roll steer's, last
    assert braking and braking[-1] is added[-3] and {e for c in braking for e, _, _ in c.effects} == {"longitudinal_load_transfer"}
    assert dict(braking[0].speed)["end_kmh"] < dict(braking[0].speed)["start_kmh"]
    partial = copy.deepcopy(config)
    partial["discrepancy"]["candidates"] = list(config["discrepancy"]["candidates"]) + ["compliance_steer"]
    assert {c.name for c in benchmark_cases(partial, samples=20)} - {c.name for c in plain} == {
        c.name for c in added if {e for e, _, _ in c.effects} & set(CHASSIS_EFFECTS) == {"compliance_steer"}}


def test_chassis_magnitudes_are_checked():
    for effect, size in [("lateral_load_transfer", 0.2), ("longitudinal_load_transfer", 0.0), ("tyre_relaxation", -0.1), ("compliance_steer", 0.0),
                         ("roll_steer", 0.0)]:
        with pytest.raises(ValueError, match=effect):
            HiddenEffectCase("x", effect, size, "step", {})


def test_lateral_load_transfer_needs_the_cars_height_and_track(calm):
    del calm["vehicle"]["cg_height"]
    with pytest.raises(ConfigError, match="vehicle.cg_height"):
        run(calm, HiddenEffectCase("x", "lateral_load_transfer", -0.3, "step", {"amplitude_deg": 1.0}))


@pytest.mark.parametrize("effect, size, sigma", [("compliance_steer", 0.8, 0.0), ("tyre_relaxation", 0.8, 0.8)])
def test_linear_chassis_effects_follow_their_state_space_model(calm, effect, size, sigma):
    """Compliance steer K (deg/g) driven by the front force: delta - K_F F_f with
    K_F = K L / (g m l_r) (rad/N, K per g at steady cornering) makes the front stiffness
    c_f / (1 + c_f K_F); relaxation adds two lagged slip angles. lsim of that model on a 1 ms grid
    (first-order hold: error ~ dt^2) against the reality's RK4 (h = 5 ms): agreement to 1e-3 of
    the peak, while the effect moves the response by 5-60 % of it (a flipped K moves it the other
    way; a flipped sigma is unstable)."""
    case = HiddenEffectCase("x", effect, size, "step", {"amplitude_deg": 2.0, "t_start": 0.3, "ramp": 0.2})
    _, x = run(calm, case)

    def front(k, p):
        K_F = np.deg2rad(size) * p["L"] / (p["g"] * p["m"][k] * p["l_r"][k]) if effect == "compliance_steer" else 0.0
        return p["c_f"][k] / (1.0 + p["c_f"][k] * K_F)

    r, beta = linear_response(calm, case, front, sigma)
    r0, _ = linear_response(calm, case, lambda k, p: p["c_f"][k])
    peak = np.abs(r).max()
    assert np.abs(r - r0).max() > 0.05 * peak  # the effect is well above the tolerance below
    assert np.abs(x[1] - r).max() < 1e-3 * peak
    assert np.abs(x[2] - beta).max() < 1e-3 * np.abs(beta).max()


def test_roll_steer_follows_the_bodys_roll_mode(calm):
    """Roll steer K (deg/g): the front wheels turn by -e_f phi, the roll angle a second-order
    mode I_x phi'' = h (F_f + F_r) + (m g h - K_phi) phi - c_phi phi' (I_x 550 kg m^2, K_phi 140 kN
    m/rad, c_phi 10.5 kN m s/rad), e_f = K / (m h g / (K_phi - m g h)) at the car's nominal mass.
    lsim of the linear model with the states r, beta, phi, phi' on a 1 ms grid against the
    reality's RK4 (h = 5 ms): 1e-3 of the peak, while the effect moves the yaw rate by more than
    5 % of it; without the roll's dynamics (the steer at the steady roll of each instant's force)
    the reality misses by more than 1 %."""
    size = 0.8
    case = HiddenEffectCase("x", "roll_steer", size, "slalom", {"amplitude_deg": 2.0, "period": 1.5})
    _, x = run(calm, case)
    p, veh = car(calm), calm["vehicle"]
    g, v = p["g"], p["v"]
    K_phi, c_phi, I_x = 140e3, 10.5e3, 550.0
    e_f = np.deg2rad(size) / (veh["m_base"] * H * g / (K_phi - veh["m_base"] * g * H))
    t_fine = np.arange(0.0, calm["time"]["t_end"] + 5e-4, 1e-3)
    delta = steering_command(case.manoeuvre, t_fine, dict(case.manoeuvre_params))
    idx = np.rint(np.arange(round(calm["time"]["t_end"] / calm["time"]["dt"]) + 1) * calm["time"]["dt"] / 1e-3).astype(int)

    def response(e, dynamic=True):
        out = []
        for k in range(3):
            m, I_z, l_f, l_r, c_f, c_r = p["m"][k], p["I_z"][k], p["l_f"][k], p["l_r"][k], p["c_f"][k], p["c_r"][k]
            F_f = c_f * np.array([-l_f / v, -1.0, -e, 0.0])  # per state [r, beta, phi, phi']
            F_r = c_r * np.array([l_r / v, -1.0, 0.0, 0.0])
            A = np.zeros((4, 4))
            A[0], A[1] = (l_f * F_f - l_r * F_r) / I_z, (F_f + F_r) / (m * v)
            A[1, 0] -= 1.0
            A[2, 3] = 1.0
            A[3] = H * (F_f + F_r) / I_x
            A[3, 2] += (m * g * H - K_phi) / I_x
            A[3, 3] -= c_phi / I_x
            B = np.array([l_f * c_f / I_z, c_f / (m * v), 0.0, H * c_f / I_x])
            if not dynamic:  # phi at its steady value of the instant's tyre force: an algebraic loop, solved
                gain = H / (K_phi - m * g * H)  # phi = gain (F_f + F_r)
                loop = 1.0 - gain * (F_f + F_r)[2]
                A2 = A[:2, :2] + np.outer(A[:2, 2], gain * (F_f + F_r)[:2]) / loop
                B2 = B[:2] + A[:2, 2] * gain * c_f / loop
                _, y, _ = lsim((A2, B2[:, None], np.eye(2), np.zeros((2, 1))), delta, t_fine)
            else:
                _, y, _ = lsim((A, B[:, None], np.eye(4), np.zeros((4, 1))), delta, t_fine)
            out.append(y[idx, 0])
        return np.array(out)

    r = response(e_f)
    peak = np.abs(r).max()
    assert np.abs(r - response(0.0)).max() > 0.05 * peak
    assert np.abs(x[1] - r).max() < 1e-3 * peak
    assert np.abs(x[1] - response(e_f, dynamic=False)).max() > 1e-2 * peak


def steady_state_steer(cfg, r, beta, front_load, axle_factor):
    """Steering angle (rad) of steady cornering at yaw rate r with linear tyres, derived from the
    balances: F_f + F_r = m v r, l_f F_f = l_r F_r, alpha_f - alpha_r = delta - L r / v, the
    stiffness B C D of each axle's peak D; ``front_load(p, a_y, beta)`` the front axle's load
    after the longitudinal transfer, ``axle_factor(p, a_y, i)`` the lateral transfer's factor."""
    p = car(cfg)
    a_y = p["v"] * r
    F_f, F_r = p["m"] * a_y * p["l_r"] / p["L"], p["m"] * a_y * p["l_f"] / p["L"]
    F_zf = front_load(p, a_y, beta)
    F_zr = p["F_fz"] + p["F_rz"] - F_zf
    c_f = p["c_f"] * F_zf / p["F_fz"] * axle_factor(p, a_y, 0)
    c_r = p["c_r"] * F_zr / p["F_rz"] * axle_factor(p, a_y, 1)
    return p["L"] * r / p["v"] + F_f / c_f - F_r / c_r, p["l_r"] * r / p["v"] - F_r / c_r


STATIC = (lambda p, a_y, beta: p["F_fz"], lambda p, a_y, i: 1.0)


def longitudinal(h):
    """Front load after the transfer by a_x = -tan(beta) a_y at cg height h (m)."""
    return lambda p, a_y, beta: p["F_fz"] + p["m"] * np.tan(beta) * a_y * h / p["L"], STATIC[1]


def lateral(p_Dz, chi_f=0.55):
    """Axle factor 1 + p_Dz (dF / F_z0)^2, dF = chi m a_y h / t (both wheels on the ground)."""
    def factor(p, a_y, i):
        dF = (chi_f, 1.0 - chi_f)[i] * p["m"] * a_y * H / TRACK
        F0 = 0.5 * (p["F_fz"], p["F_rz"])[i]
        assert np.all(dF < F0)
        return 1.0 + p_Dz * (dF / F0) ** 2
    return STATIC[0], factor


@pytest.mark.parametrize("effect, size, amplitude, model, wrong", [
    ("lateral_load_transfer", -0.3, 4.0, lateral(-0.3), [STATIC, lateral(0.3), lateral(-0.3, chi_f=0.45)]),
    ("longitudinal_load_transfer", 1.5, 4.0, longitudinal(1.5), [STATIC, longitudinal(-1.5)]),
])
def test_load_transfer_steady_cornering(calm, effect, size, amplitude, model, wrong):
    """At the end of a 4 deg step steer (settled: 2 s after the ramp, ~10 yaw time constants),
    the reality's yaw rate and side slip satisfy the steady balances with the transferred loads
    (steady_state_steer) to 1e-6 of the steering angle (fixed-point and RK4 error); without the
    transfer, with its sign flipped or (lateral) with the other axle's share the balance misses
    by ~10 times that or more."""
    case = HiddenEffectCase("x", effect, size, "step", {"amplitude_deg": amplitude, "t_start": 0.3, "ramp": 0.2})
    _, x = run(calm, case)
    r, beta, delta = x[1, :, -1], x[2, :, -1], np.deg2rad(amplitude)
    assert np.abs(x[1, :, -1] - x[1, :, -11]).max() < 1e-9  # settled
    steer, beta_ss = steady_state_steer(calm, r, beta, *model)
    tol = 1e-6 * delta
    assert np.abs(steer - delta).max() < tol and np.abs(beta_ss - beta).max() < 1e-6 * np.abs(beta).max() + 1e-9
    for other in wrong:
        assert np.abs(steady_state_steer(calm, r, beta, *other)[0] - delta).max() > 10 * tol

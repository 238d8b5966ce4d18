import numpy as np
import pytest

from uqdrive.wheelslip.quarter_car import (
    QuarterCar,
    closed_loop_poles,
    damping,
    damping_bounds,
    friction_curve,
    friction_slope,
    pid_gains,
    pid_schedule,
    simulate_closed_loop,
)
from uqdrive.settings import Settings

CAR = QuarterCar()


def test_constants_match_facts(config):
    car = QuarterCar.from_settings(Settings.from_config(config).wheelslip)
    assert car.alpha == pytest.approx(0.5147, abs=5e-5)
    assert car.beta == pytest.approx(441.8, abs=0.05)


def test_friction_curve_peak_and_slope():
    lam = np.linspace(0, 1, 100001)
    for mu_H in (0.3, 0.9, 1.1):
        mu = friction_curve(lam, mu_H)
        assert mu.max() == pytest.approx(mu_H, abs=1e-8)
        assert lam[mu.argmax()] == pytest.approx(0.2 * mu_H, abs=1e-4)
    assert friction_slope(0.15, 0.9) == pytest.approx(0.3882, abs=5e-5)  # FACTS
    assert friction_slope(0.0, 0.9) == pytest.approx(28.0)
    h = 1e-6
    assert friction_slope(0.3, 0.7) == pytest.approx((friction_curve(0.3 + h, 0.7) - friction_curve(0.3 - h, 0.7)) / (2 * h), rel=1e-7)


def test_paper_golden_values():
    """FACTS: E(Gamma) = -0.0787, var 0.1610 give K_p = 122.07 v + 67.55, T_i = 0.0159 + 0.0088 / v,
    zeta+ = 0.5940 and zeta- = 0.4060 at v = 30 m/s."""
    s = pid_schedule(-0.0787, CAR)
    assert s["K_p_per_v"] == pytest.approx(122.07, abs=0.005)
    assert s["K_p_offset"] == pytest.approx(67.55, abs=0.005)
    assert s["T_i_offset"] == pytest.approx(0.0159, abs=5e-5)
    assert s["T_i_per_inv_v"] == pytest.approx(0.0088, abs=5e-5)
    K_p, T_i, T_d = pid_gains(-0.0787, 30.0, CAR)
    assert K_p == pytest.approx(122.07 * 30 + 67.55, abs=0.2) and T_d == CAR.T_a
    hi, lo = damping_bounds(-0.0787, np.sqrt(0.1610), 30.0, K_p, T_i, CAR)
    assert (hi, lo) == pytest.approx((0.5940, 0.4060), abs=5e-5)
    zeta, omega = damping(-0.0787, 30.0, K_p, T_i, CAR)
    assert zeta == pytest.approx(0.5) and omega == pytest.approx(20 * np.pi)


def test_poles_of_21():
    p = closed_loop_poles(0.5, 10.0)
    assert np.allclose(p**2 + 2 * 0.5 * 10 * p + 100, 0)
    assert np.abs(p) == pytest.approx([10.0, 10.0])


def test_closed_loop_reaches_set_point_on_the_true_curve():
    K = lambda v: pid_gains(0.3882, v, CAR)[0]  # noqa: E731
    T = lambda v: pid_gains(0.3882, v, CAR)[1]  # noqa: E731
    t, x = simulate_closed_loop(lambda lam: friction_curve(lam, 0.9), CAR, K, T, 30.0, 0.05, 0.3, 1e-4)
    assert abs(x[-1, 1, 0] - CAR.lambda_star) < 0.005
    assert x[-1, 0, 0] < 30.0  # braking
    assert np.all(x[:, 1, 0] < 1.0)


def test_z95_is_the_normal_quantile():
    """calibration.Z95 is written as a number so that scipy.stats loads only where it is used."""
    from scipy.stats import norm

    from uqdrive.wheelslip.calibration import Z95

    assert Z95 == pytest.approx(norm.ppf(0.975), rel=1e-15)

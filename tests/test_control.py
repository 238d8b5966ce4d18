import numpy as np
import pytest

from uqdrive.control.lqr import lqr_gain
from uqdrive.vehicle.single_track import VehicleParameters, lst_matrices
from uqdrive.settings import Settings


def test_lqr_gain_of_mean_lst_matches_facts(config):
    A, B, _ = lst_matrices(VehicleParameters.from_settings(Settings.from_config(config)))
    K = lqr_gain(A, B, np.diag([1.0, 1.0, 1.0, 10.0]), 100.0)
    # FACTS: K = [-1.854, -0.052, -0.487, -0.316] (3 decimals), eq. (6.1) prints 2.
    assert K[0] == pytest.approx([-1.854, -0.052, -0.487, -0.316], abs=5e-4)
    closed = np.linalg.eigvals(A + B[:, None] @ K)
    assert np.all(closed.real < 0)


def test_lqr_of_scalar_integrator_closed_form():
    # x' = u, Q = q, R = r: P = sqrt(q r), K = -sqrt(q / r).
    K = lqr_gain([[0.0]], [1.0], [[4.0]], 1.0)
    assert K[0, 0] == pytest.approx(-2.0)


def test_riccati_solution_satisfies_the_are(config):
    """K = -R^-1 B'P with P solving A'P + PA - P B R^-1 B'P + Q = 0 (scipy), checked by residual."""
    from scipy.linalg import solve_continuous_are

    A, B, _ = lst_matrices(VehicleParameters.from_settings(Settings.from_config(config)))
    Q, R = np.diag([1.0, 1.0, 1.0, 10.0]), np.array([[100.0]])
    P = solve_continuous_are(A, B[:, None], Q, R)
    residual = A.T @ P + P @ A - P @ B[:, None] @ np.linalg.solve(R, B[None, :] @ P) + Q
    assert np.abs(residual).max() < 1e-8 * np.abs(P).max()
    assert lqr_gain(A, B, Q, R) == pytest.approx(-np.linalg.solve(R, B[None, :] @ P))

import numpy as np
import pytest

from uqdrive.control import lqr_gain
from uqdrive.vehicle import VehicleParameters, lst_matrices


def test_lqr_gain_of_mean_lst_matches_facts(config):
    A, B, _ = lst_matrices(VehicleParameters.from_config(config))
    K = lqr_gain(A, B, np.diag([1.0, 1.0, 1.0, 10.0]), 100.0)
    # FACTS: K = [-1.854, -0.052, -0.487, -0.316] (3 decimals), eq. (6.1) prints 2.
    assert K[0] == pytest.approx([-1.854, -0.052, -0.487, -0.316], abs=5e-4)
    closed = np.linalg.eigvals(A + B[:, None] @ K)
    assert np.all(closed.real < 0)


def test_lqr_of_scalar_integrator_closed_form():
    # x' = u, Q = q, R = r: P = sqrt(q r), K = -sqrt(q / r).
    K = lqr_gain([[0.0]], [1.0], [[4.0]], 1.0)
    assert K[0, 0] == pytest.approx(-2.0)

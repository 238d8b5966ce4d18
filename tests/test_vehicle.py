import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from conftest import REPO
from uqdrive.config import load_config
from uqdrive.vehicle.dynamics import SingleTrackRHS, nlst_rhs
from uqdrive.vehicle.single_track import VehicleParameters, lst_matrices, magic_formula, steering_input
from uqdrive.settings import Settings


@pytest.fixture
def nominal(config):
    return VehicleParameters.from_settings(Settings.from_config(config))


def test_derived_parameters_match_facts(nominal):
    # FACTS: c_f = 169788 N/rad, c_r = 580582 N/rad, I_z = 1582.56 kg m^2 at the mean parameters.
    assert nominal.c_f == pytest.approx(169788.34, abs=0.01)
    assert nominal.c_r == pytest.approx(580582.48, abs=0.01)
    assert nominal.I_z == pytest.approx(1582.56, abs=1e-9)
    assert nominal.v_c == pytest.approx(70 / 3.6)


def test_open_loop_eigenvalues_match_facts(nominal):
    A, _, _ = lst_matrices(nominal)
    eig = np.sort(np.linalg.eigvals(A).real)
    assert eig == pytest.approx([-40.28, -25.35, 0.0, 0.0], abs=0.005)


def test_magic_formula_slope_at_origin_is_FzBCD():
    h = 1e-7
    slope = (magic_formula(h, 1000.0, 10.6, 1.9, 0.8, 0.97) - magic_formula(-h, 1000.0, 10.6, 1.9, 0.8, 0.97)) / (2 * h)
    assert slope == pytest.approx(1000.0 * 10.6 * 1.9 * 0.8, rel=1e-8)


def _jacobian(f, x0, eps=1e-7):
    cols = []
    for i in range(x0.size):
        e = np.zeros_like(x0)
        e[i] = eps
        cols.append((f(x0 + e) - f(x0 - e)) / (2 * eps))
    return np.stack(cols, axis=-1)


def test_nlst_linearisation_is_the_lst(nominal):
    """The Jacobians of (5.3) at rest are A, B and W of (5.4): the corrected rows of FACTS."""
    A, B, W = lst_matrices(nominal)
    x0 = np.zeros(4)
    J = _jacobian(lambda x: nlst_rhs(x[:, None], 0.0, 0.0, nominal)[:, 0], x0)
    assert J == pytest.approx(A, rel=1e-6, abs=1e-6)
    dB = (nlst_rhs(x0[:, None], 1e-7, 0.0, nominal) - nlst_rhs(x0[:, None], -1e-7, 0.0, nominal))[:, 0] / 2e-7
    assert dB == pytest.approx(B, rel=1e-6)
    dW = (nlst_rhs(x0[:, None], 0.0, 1.0, nominal) - nlst_rhs(x0[:, None], 0.0, -1.0, nominal))[:, 0] / 2.0
    assert dW == pytest.approx(W, rel=1e-9)


def test_lst_matrices_broadcast_over_realisations(config):
    p = VehicleParameters.from_settings(Settings.from_config(config), mu=np.array([0.8, 1.0, 1.2]), l_f=np.array([1.4, 1.55, 1.7]))
    A, B, W = lst_matrices(p)
    assert A.shape == (3, 4, 4) and B.shape == (3, 4) and W.shape == (3, 4)
    single = lst_matrices(VehicleParameters.from_settings(Settings.from_config(config), mu=1.2, l_f=1.7))
    assert A[2] == pytest.approx(single[0])


@settings(max_examples=40, deadline=None)
@given(
    x=st.lists(st.floats(-0.5, 0.5), min_size=4, max_size=4),
    delta=st.floats(-0.2, 0.2),
    wind=st.floats(-800, 800),
    mu=st.floats(0.3, 1.6),
    l_f=st.floats(1.0, 2.0),
)
def test_the_balances_two_roundings_agree(config, x, delta, wind, mu, l_f):
    p = VehicleParameters.from_settings(Settings.from_config(config), mu=np.array([mu, 1.0]), l_f=np.array([l_f, 1.55]))
    X = np.array([x, x]).T
    ref = nlst_rhs(X, delta, wind, p)
    fast = SingleTrackRHS(p, n=2).rates(X, delta, wind)
    assert fast == pytest.approx(ref, rel=1e-12, abs=1e-12)


def test_steering_inputs_5_5_and_5_7():
    t = np.array([0.0, 1.0, 2.0, 4.0])
    d = steering_input(t, np.pi / 36, 4.0)
    assert d == pytest.approx(np.pi / 36 * np.array([1.0, 0.0, -1.0, 1.0]), abs=1e-15)
    assert steering_input(t, np.pi / 36, 4.0, -1.0) == pytest.approx(-d)


@settings(max_examples=40, deadline=None)
@given(st.lists(st.floats(-0.3, 0.3), min_size=4, max_size=4), st.floats(-0.1, 0.1), st.floats(-800, 800), st.floats(0.3, 1.5))
def test_nlst_is_odd_in_state_steering_and_wind(x, delta, F_w, mu):
    """(5.3) is odd: f(-x, -delta, -F_w) = -f(x, delta, F_w). So inverted steering (5.7) with
    mirrored wind gives the mirrored ensemble, and an estimate of the mean wind from inverted
    data must be the mirror of the normal-steering one (Table 6.3 discussion, docs/reproduction.md)."""
    p = VehicleParameters.from_settings(Settings.from_config(load_config(REPO / "config" / "config.yaml")), mu=np.array([mu]), m_load=np.array([100.0]), l_f=np.array([1.55]))
    xs = np.array(x)[:, None]
    f = SingleTrackRHS(p, n=1).rates
    assert f(-xs, -delta, -np.array([F_w])) == pytest.approx(-f(xs, delta, np.array([F_w])), rel=1e-12, abs=1e-12)

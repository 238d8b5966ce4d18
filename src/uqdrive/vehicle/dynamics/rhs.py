"""The right-hand side of the non-linear single-track model (5.3), written once: slip angles,
tyre forces, the yaw and lateral balances and the course kinematics, for n realisations at once.

Every non-linear simulator integrates :class:`SingleTrackRHS`: the ensemble simulator's
structures without chassis terms (:mod:`uqdrive.vehicle.dynamics.engine`: the Monte Carlo data
sets and :mod:`uqdrive.vehicle.augmented`), the
closed-loop study and the reference solutions (:func:`nlst_rhs`); the chassis right-hand side
(:mod:`uqdrive.vehicle.track_extended`) shares its slip angles (:func:`slip_angles`) and balances
(:class:`Balance`). What differs between the simulators is where the inputs come from per RK4 half
step (:class:`HalfStepInputs`, :class:`GustInputs`) and which terms are on (tyre law, course
weight, road bank, speed profile, the states integrated).

The right-hand side writes into preallocated arrays (positional ``out``: NumPy parses an ``out=``
keyword in ~0.3 us more per call), so a step allocates nothing; at the 300 realisations of a
discover fit the per-call cost is most of a step. The sines and cosines of the side slip and of
the tyre's angle come from the half-angle tangent (:func:`uqdrive.vehicle.axle_loads.half_angle_sin_cos_into`): NumPy does not
vectorise its float64 sine and cosine, and at the 2400 realisations of a batched fit they were
most of a step. The arithmetic is fixed to the last bit (the package's data sets are remade
exactly, tests/test_single_track_rhs.py): the balances keep the two roundings the data sets were
made with: the augmented model and the ensembles' states at constant speed multiply by 1 / I_z
and 1 / (m v); the ensembles along a speed profile and their lateral acceleration divide by I_z
and m v (``quotient``).
"""

from __future__ import annotations

import numpy as np

from ..axle_loads import half_angle_sin_cos_into
from ..single_track import VehicleParameters, tyre_angle

#: The Magic-Formula rates by :class:`.fused_rates.FusedRates` (the arithmetic compiled, the same
#: numbers); False: the NumPy operations below alone (the reference the tests compare with).
FUSED = True

__all__ = ["slip_angles", "Balance", "HalfStepInputs", "GustInputs", "SingleTrackRHS", "nlst_rhs"]


def slip_angles(v, sin_b, cos_b, lever, psi_dot, delta, out=None, work=None):
    """Front and rear slip angles of (5.3g, h), -atan((v sin beta + lever psi_dot) / (v cos beta)),
    the front's plus the steering angle.

    Parameters
    ----------
    v : float
        Speed (m/s).
    sin_b, cos_b : ndarray, shape (n,)
        sin and cos of the side-slip angle beta (-).
    lever : ndarray, shape (2, n)
        [l_f, -l_r] (m).
    psi_dot : ndarray, shape (n,)
        Yaw rate (rad/s).
    delta : float or ndarray, shape (n,)
        Front wheel angle (rad).
    out : ndarray, shape (2, n), optional
        Takes the slip angles (rad); ``work`` (n,) a temporary (the RK4 loops pass both, else allocated).

    Returns
    -------
    ndarray, shape (2, n)
        alpha_f, alpha_r (rad).
    """
    out = np.multiply(lever, psi_dot, out)
    work = np.multiply(sin_b, v, work)
    out += work
    np.multiply(cos_b, v, work)
    out /= work
    np.arctan(out, out)
    np.negative(out, out)
    out[0] += delta
    return out


class Balance:
    """The yaw and lateral balances of (5.3a, b): psi_ddot = (l_f F_f cos delta - l_r F_r + M_w) / I_z
    and beta_dot = (F_f cos delta + F_r + F_w) cos beta / (m v) - psi_dot, in place.

    Parameters
    ----------
    p : VehicleParameters
        Per-realisation parameters (arrays of shape (n,) or scalars).
    quotient : bool
        Divide by I_z and m v (else multiply by their inverses; the two round differently in the
        last bit, see the module's docstring).
    """

    def __init__(self, p: VehicleParameters, quotient: bool = False):
        self.l_f, self.l_r, self.M_c = np.asarray(p.l_f, float), p.l_r, p.M_c
        self.quotient = bool(quotient)
        self.scale = np.divide if quotient else np.multiply
        self.yaw_factor = p.I_z if quotient else 1.0 / p.I_z

    def mass_factor(self, m, v):
        """The factor of the lateral balance at speed ``v`` (m/s) for the mass ``m`` (kg, (n,)): m v
        (``quotient``) or 1 / (m v)."""
        return m * v if self.quotient else 1.0 / (m * v)

    def rates(self, front, F_r, F_w, M_w, psi_dot, cos_b, mass_factor, yaw_out, slip_out, work) -> None:
        """psi_ddot into ``yaw_out`` (n,) (rad/s^2) and beta_dot into ``slip_out`` (n,) (rad/s).

        ``front`` (n,) is F_f cos delta (N), ``F_r`` (n,) the rear force (N), ``F_w`` (n,) the side
        wind (N), ``M_w`` (n,) its yaw moment (N m; None: M_c F_w, (5.3f)), ``cos_b`` (n,) cos beta
        (None: the LST's 1), ``mass_factor`` of :meth:`mass_factor`; ``work`` (n,) a temporary.
        """
        np.multiply(self.l_f, front, yaw_out)
        np.multiply(self.l_r, F_r, work)
        yaw_out -= work
        if M_w is None:
            np.multiply(F_w, self.M_c, work)
            yaw_out += work
        else:
            yaw_out += M_w
        self.scale(yaw_out, self.yaw_factor, yaw_out)
        np.add(front, F_r, slip_out)
        slip_out += F_w
        if cos_b is not None:
            slip_out *= cos_b
        self.scale(slip_out, mass_factor, slip_out)
        slip_out -= psi_dot


class HalfStepInputs:
    """The inputs tabulated on the RK4 half-step grid.

    Parameters
    ----------
    delta_half : ndarray, shape (J,) or (J, n)
        Actual front wheel angle (rad) per half step (and realisation).
    F_w_half : ndarray, shape (J, n)
        Side wind (N) per half step and realisation.
    M_w : ndarray, shape (n,), optional
        A constant wind yaw moment (N m: M_c times the mean wind where the gusts act laterally
        only); None: M_c F_w.
    """

    def __init__(self, delta_half, F_w_half, M_w=None):
        self.delta_half = np.asarray(delta_half, float)
        self.cos_delta = np.cos(self.delta_half)
        self.F_w_half, self.M_w, self.n = F_w_half, M_w, F_w_half.shape[1]

    def at(self, j: int):
        """delta, cos delta, F_w and M_w at half step ``j``."""
        return self.delta_half[j], self.cos_delta[j], self.F_w_half[j], self.M_w


class GustInputs:
    """The inputs of a Monte Carlo ensemble: the steering on the half-step grid and the wind
    F_w = F_w_mean + c f(t) of (5.1), (5.21), its gusts formed per half step (a product of the
    realisations' mode coefficients with the eigenfunctions there: no (J, n) table in memory).

    Parameters
    ----------
    delta_half : ndarray, shape (J,)
        Front wheel angle (rad) on the half-step grid.
    wind_mean : ndarray, shape (n,)
        Mean side wind (N).
    coeffs : ndarray, shape (n, n_c)
        Wind mode coefficients (N).
    eigenfunctions_half : ndarray, shape (n_c, J)
        KLE eigenfunctions on the half-step grid (-).
    M_w : ndarray, shape (n,), optional
        A constant wind yaw moment (N m), as :class:`HalfStepInputs`.
    """

    def __init__(self, delta_half, wind_mean, coeffs, eigenfunctions_half, M_w=None):
        self.delta_half = np.asarray(delta_half, float)
        self.cos_delta = np.cos(self.delta_half)
        self.wind_mean, self.coeffs = np.asarray(wind_mean, float), np.asarray(coeffs, float)
        self.f_half = np.ascontiguousarray(np.asarray(eigenfunctions_half, float).T)  # (J, n_c)
        self.M_w, self.n = M_w, self.wind_mean.shape[0]
        self._j, self._F_w = -1, None  # RK4 asks for every half step twice in a row

    def at(self, j: int):
        """delta, cos delta, F_w and M_w at half step ``j``."""
        if j != self._j:
            self._j, self._F_w = j, self.wind_mean + self.coeffs @ self.f_half[j]
        return self.delta_half[j], self.cos_delta[j], self._F_w, self.M_w


class SingleTrackRHS:
    """dx/dt of the single-track model (5.3) with a Magic-Formula (or linear) tyre, the course
    kinematics y_dot = v sin(psi + k beta), a lateral acceleration on the body (road bank) and an
    optional speed profile, for n realisations; ``rhs(x, j, out)`` writes dx/dt at half step j.

    Parameters
    ----------
    p : VehicleParameters
        Per-realisation parameters (mu, l_f, m_load arrays of shape (n,) or scalars).
    inputs : HalfStepInputs or GustInputs, optional
        The inputs per half step (None: only :meth:`rates`, with ``n`` given).
    n : int, optional
        Realisations, where ``inputs`` is None.
    tyre : {"magic_formula", "linear"}
        Pacejka's Magic Formula (2.2a) or the linear c alpha.
    E : float or ndarray, shape (n,), optional
        Magic-Formula curvature factor (-); None: ``p.E``.
    course_weight : float or ndarray, shape (n,)
        k of the course angle psi + k beta (-); 0: the thesis' heading psi.
    lateral_acceleration : float or ndarray, shape (n,)
        a_lat (m/s^2) on the body without yaw moment (road bank): beta_dot gains a_lat / v.
    speed_half : tuple of two ndarrays, shape (J,), optional
        Speed v (m/s) and its rate v_dot (m/s^2) per half step (v_dot may be None: no speed
        change term); the speed change acts along the velocity, so beta_dot gains
        -(v_dot / v) sin beta; None: ``p.v_c``.
    heading : bool
        Integrate psi and y too; False: the states are psi_dot and beta alone (2, n), which
        neither psi nor y enters, for sensors that record neither (the same numbers for both).
    quotient : bool
        The balances divide by I_z and m v (:class:`Balance`).
    """

    def __init__(self, p: VehicleParameters, inputs=None, *, n: int | None = None, tyre: str = "magic_formula", E=None, course_weight=0.0,
                 lateral_acceleration=0.0, speed_half=None, heading: bool = True, quotient: bool = False):
        self.inputs = inputs
        self.n = n = inputs.n if inputs is not None else int(n)
        self.heading, self.n_states = bool(heading), 4 if heading else 2
        self._rows = (1, 2) if heading else (0, 1)  # psi_dot's and beta's rows of the integrated states
        per = lambda a: np.broadcast_to(a, (n,))  # noqa: E731 (one value per realisation)
        self.v = v = float(p.v_c)
        self.balance = Balance(p, quotient)
        self.lever = np.stack([per(self.balance.l_f), per(-p.l_r)])
        self.saturating = tyre == "magic_formula"
        self.Bs = np.array([[p.c_Sf], [p.c_Sr]])
        self.peak = np.stack([per(p.F_fz * p.mu), per(p.F_rz * p.mu)])
        self.linear = np.stack([per(p.c_f), per(p.c_r)])
        self.C, self.E = p.C, (p.E if E is None else E)
        self.k = course_weight
        self._course = np.ndim(course_weight) > 0 or course_weight != 0
        self.a_lat = lateral_acceleration
        self._lateral = bool(np.any(np.asarray(lateral_acceleration) != 0))
        self.a_v = lateral_acceleration / v if self._lateral else None
        self.m = p.m
        self.mass_factor = self.balance.mass_factor(p.m, v)
        self.speed_half = self.v_dot_half = None
        if speed_half is not None:
            self.speed_half = np.asarray(speed_half[0], float)
            self.v_dot_half = None if speed_half[1] is None else np.asarray(speed_half[1], float)
            self.inv_m = 1.0 / p.m
        self._sin_b, self._cos_b, self._t, self._fc, self._tmp = (np.empty(n) for _ in range(5))
        self._q, self._bx, self._F = np.empty((2, n)), np.empty((2, n)), np.empty((2, n))
        # the tyre's angle C atan(u) stays below C pi / 2: its sine by the half-angle tangent
        # while that is clear of pi (tan(angle / 2) is infinite at pi)
        self._half_angle_tyre = bool(np.all(np.asarray(self.C) * 0.5 * np.pi < 3.0))
        self._fused = None
        if FUSED and self._fusable():
            from .fused_rates import FusedRates

            self._fused = FusedRates(self.lever, self.peak, self.Bs[:, 0], self.C, self.E, self.balance.l_f, self.balance.l_r, p.M_c,
                                     self.balance.yaw_factor, self.balance.quotient, course_weight if self._course else None, heading)

    @classmethod
    def of_structure(cls, p: VehicleParameters, s, E, delta_half, F_w_half, yaw_gust: bool, wind, speed_half=None,
                     heading: bool = True) -> "SingleTrackRHS":
        """The right-hand side of a :class:`~uqdrive.vehicle.effects.ModelStructure`'s ``tyre``,
        ``course_weight`` and ``lateral_acceleration`` (scalars or arrays (n,)) on tabulated inputs:
        ``delta_half``, ``F_w_half`` as :class:`HalfStepInputs`, ``yaw_gust`` whether the gusts
        exert the yaw moment M_c F_w too (else M_c times the mean ``wind`` (n,), N)."""
        M_w = None if yaw_gust else p.M_c * np.asarray(wind, float)
        return cls(p, HalfStepInputs(delta_half, F_w_half, M_w), tyre=s.tyre, E=E, course_weight=s.course_weight,
                   lateral_acceleration=s.lateral_acceleration, speed_half=speed_half, heading=heading)

    def _at(self, j: int):
        """Speed, the lateral balance's mass factor, a_lat / v (None: no bank) and v_dot (None:
        none) at half step ``j`` (the constants without a profile)."""
        if self.speed_half is None:
            return self.v, self.mass_factor, self.a_v, None
        v = float(self.speed_half[j])
        mass = self.m * v if self.balance.quotient else self.inv_m / v  # (1 / m) / v: the augmented model's rounding along a profile
        return v, mass, (self.a_lat / v if self._lateral else None), (None if self.v_dot_half is None else self.v_dot_half[j])

    @property
    def fused(self) -> bool:
        """Whether the rates are :class:`.fused_rates.FusedRates`' (the same numbers as the NumPy operations)."""
        return self._fused is not None

    def _fusable(self) -> bool:
        """Whether :class:`.fused_rates.FusedRates` computes these rates: the Magic Formula with the
        half-angle sine, one B per axle, one C, real float64 constants (a complex step takes NumPy's path)."""
        real = all(np.asarray(a).dtype == np.float64 for a in (self.lever, self.peak, self.Bs, self.E, self.C, self.balance.yaw_factor,
                                                                 self.mass_factor, self.k, self.a_lat))
        return self.saturating and self._half_angle_tyre and real and self.Bs.shape == (2, 1) and np.ndim(self.C) == 0 and np.ndim(self.E) <= 1

    def __call__(self, x, j: int, out) -> None:
        """dx/dt (n_states, n) of the states ``x`` (n_states, n) at half step ``j`` into ``out``."""
        self._rates(x, out, *self.inputs.at(j), *self._at(j))

    def rates(self, x, delta, F_w, M_w=None):
        """dx/dt (4, n) of ``x`` (4, n) at the speed ``p.v_c`` for the inputs given, without a
        speed profile: ``delta`` (rad) and ``F_w`` (N), floats or arrays (n,), ``M_w`` (N m; None:
        M_c F_w)."""
        out = np.empty_like(x)
        self._rates(x, out, delta, np.cos(delta), F_w, M_w, *self._at(0))
        return out

    def _rates(self, x, out, delta, cos_delta, F_w, M_w, v, mass_factor, a_v, v_dot) -> None:
        if self._fused is not None and x.dtype == np.float64:
            self._fused(x, out, delta, cos_delta, F_w, M_w, v, mass_factor, a_v, v_dot)
            return
        psi_dot, beta = x[self._rows[0]], x[self._rows[1]]
        sin_b, cos_b, q, F = self._sin_b, self._cos_b, self._q, self._F
        half_angle_sin_cos_into(beta, sin_b, cos_b, self._t, self._tmp)
        slip_angles(v, sin_b, cos_b, self.lever, psi_dot, delta, q, self._t)
        if self.saturating:  # D sin(C atan(B a - E (B a - atan(B a))))
            np.multiply(self.Bs, q, self._bx)
            tyre_angle(self._bx, self.C, self.E, F)
            if self._half_angle_tyre:
                half_angle_sin_cos_into(F, F, None, self._bx, self._q)
            else:
                np.sin(F, F)
            F *= self.peak
        else:
            np.multiply(self.linear, q, F)
        front = self._fc
        np.multiply(F[0], cos_delta, front)
        slip_rate = out[self._rows[1]]
        self.balance.rates(front, F[1], F_w, M_w, psi_dot, cos_b, mass_factor, out[self._rows[0]], slip_rate, self._tmp)
        if a_v is not None:
            slip_rate += a_v
        if v_dot is not None:
            slip_rate -= v_dot / v * sin_b
        if not self.heading:
            return
        out[0] = psi_dot
        y_rate = out[3]  # v sin(psi + k beta)
        if self._course:
            np.multiply(beta, self.k, y_rate)
            y_rate += x[0]
            np.sin(y_rate, y_rate)
        else:
            np.sin(x[0], y_rate)
        y_rate *= v

    def lateral_acceleration(self, x, j: int):
        """a_y (m/s^2), shape (n,), of ``x`` (4, n) at half step ``j``: the lateral forces over
        the mass, (F_f cos delta + F_r + F_w) / m, recovered from beta_dot of the right-hand side."""
        states = x if self.heading else x[1:3]  # x holds all four states either way
        out = np.empty_like(states)
        self(states, j, out)
        v, _, a_v, v_dot = self._at(j)
        a_y = out[self._rows[1]] + x[1]
        if a_v is not None:
            a_y -= a_v
        if v_dot is not None:
            a_y += v_dot / v * np.sin(x[2])
        return a_y * v / np.cos(x[2])


def nlst_rhs(x, delta, F_w, p: VehicleParameters, M_w=None):
    """Right-hand side of the non-linear single-track model, thesis (5.3a)-(5.3h).

    Parameters
    ----------
    x : ndarray, shape (4, n)
        States [psi (rad), psi_dot (rad/s), beta (rad), y (m)] of n realisations.
    delta : float or ndarray, shape (n,)
        Front steering angle (rad).
    F_w : float or ndarray, shape (n,)
        Side-wind force (N).
    p : VehicleParameters
        Per-realisation parameters with arrays of shape (n,) or scalars.
    M_w : float or ndarray, shape (n,), optional
        Wind yaw moment (N m); M_c F_w by default, (5.3f).

    Returns
    -------
    ndarray, shape (4, n)
        Time derivative of ``x``.
    """
    x = np.asarray(x, float)
    return SingleTrackRHS(p, n=x.shape[1], quotient=True).rates(x, delta, F_w, M_w)

"""Right-hand side of the single-track model (5.3) with the chassis effects of a real car: load
transfer (longitudinal from the body's acceleration, at held speed or along a measured speed
profile; lateral with tyre load sensitivity), compliance steer and tyre relaxation; for the
augmented simulator.

Only structures that use one of these terms come here; the thesis' structures keep
:class:`uqdrive.vehicle.dynamics.rhs.SingleTrackRHS`, to the last bit, whose Magic-Formula slip angles
and yaw and lateral balances this one shares (:func:`uqdrive.vehicle.dynamics.rhs.slip_angles`,
:class:`uqdrive.vehicle.dynamics.rhs.Balance`). Here the sines and cosines
come from the half angle's tangent (:func:`uqdrive.vehicle.axle_loads.half_angle_sin_cos`: within an ulp of NumPy's, at a
third of the cost, NumPy vectorising tan and not the float64 sine), and a state's trigonometry
and the tyres' per-unit-peak force are computed once for every term and every step of the loads'
loop that needs them; the arithmetic between them runs compiled where it can
(:mod:`uqdrive.vehicle.dynamics.fused_chassis`, on the linear tyre
:mod:`uqdrive.vehicle.dynamics.fused_linear`, the same numbers; ``FUSED`` False keeps NumPy's).

The loads follow the force the tyres carry, as a real car's do: the roll moment of their lateral
force T = F_f cos(delta) + F_r about the centre of gravity moves h T / t across the track, and the
body's acceleration along x (Rajamani, *Vehicle Dynamics and Control*, eq. (2.27): with v_x =
v cos(beta), v_y = v sin(beta), a_x = v_x' - psi_dot v_y, a_y = v_y' + psi_dot v_x)

    a_x = v' cos(beta) - tan(beta) (a_y - v' sin(beta)),   a_y = (T + F_w) / m + a_lat,

moves load along the wheelbase: at held speed (v' = 0) the drive force that holds it is -tan(beta)
times the lateral one; along a speed profile v(t) the drive or brake force that follows it adds
v' cos(beta) (braking in a turn: the front axle loaded by m |v'| h / L). T depends on the loads it
makes; the loop is solved by Newton's method from the steady guess m v psi_dot cos(beta) (whose
error is the transient m v beta_dot), compiled where it is arithmetic alone
(:mod:`uqdrive.vehicle.dynamics.load_newton`, the same numbers). The speed change acts along the velocity as in
:class:`uqdrive.vehicle.dynamics.rhs.SingleTrackRHS` (beta_dot gains -(v' / v) sin beta).

The kinematics are the baseline's, so that a chassis effect adds its own term and nothing else:
with the Magic-Formula tyre those of the NLST (5.3) (slip angles by arctan, F_f cos delta, beta_dot
with cos beta, y_dot = v sin(psi + k beta)); with the linear tyre those of the LST (5.4) (small
angles, y_dot = v (psi + k beta), its sine only where ``course_exact``, as
:class:`uqdrive.vehicle.track_rk4.LinearTrackRHS`). The loads take the body's accelerations with
their trigonometry either way.

Axle loads (Gillespie, *Fundamentals of Vehicle Dynamics*, eq. (2-4) and ch. 6)::

    F_zf = m (g l_r - a_x h_x) / L,   F_zr = m (g l_f + a_x h_x) / L
    dF_i = chi_i h T / t               (lateral transfer per wheel, chi_f + chi_r = 1)

Per wheel the peak is mu F_z (1 + p_Dz dfz), dfz = (F_z - F_z0) / F_z0 (Pacejka (4.E13)), with F_z0
the static wheel load; an axle's two wheels (loads F_zi / 2 -+ dF_i, same slip) then carry the
single-track force with the load F_zi replaced by

    P_i = (1 - p_Dz) F_zi + p_Dz (F_zi^2 / 2 + 2 dF_i^2) / F_z0,i,

so that with p_Dz < 0 the lateral transfer lowers the axle's force by p_Dz (dF_i / F_z0,i)^2 of it
(computed per wheel, so that a lifted wheel, dF_i > F_zi / 2, carries nothing and no peak turns
negative: a spinning realisation stays finite).
Compliance steer: the front wheels yield to the front axle's lateral force, delta_f = delta -
kappa F_f with kappa = K / F_zf,static (K in rad per g: at steady cornering -K per g of lateral
acceleration; positive K understeers). The loop F_f = F(alpha_f - kappa F_f) is solved exactly on
the linear tyre (F_f = c alpha_f / (1 + kappa c) at the axle's current load c) and by Newton's
method on the Magic Formula; a relaxing tyre's force comes from its lagged slip, and the wheels
yield to it without a loop. Roll steer turns the front wheels by -eps, the steer following the
tyres' force through the body's roll mode: eps'' = omega^2 (kappa_r T - eps) - 2 zeta omega eps',
kappa_r = K / (m_base g) (K in rad per g at the base mass; a roll angle phi'' = omega^2 (h T / (K_phi - m g h) - phi) -
2 zeta omega phi' times the steer per roll angle), two extra states. Tyre relaxation lags each axle's slip angle: alpha' = (alpha_ss - alpha) v cos(beta) / sigma
(Pacejka sec. 7.2), two extra states. Combined slip (the friction ellipse, Wong, *Theory of Ground
Vehicles*, sec. 1.4.4): the longitudinal force F_x = m a_x that follows the speed, shared
chi_d : 1 - chi_d front : rear when it drives and by the static loads when it brakes, leaves axle i
the share sqrt(1 - (kappa F_x,i / (mu P_i))^2) of its lateral force (none when it takes all).
Load-sensitive tyre (Pacejka, *Tyre and Vehicle Dynamics*, (4.E13), (4.E25) linearised): axle i's peak and
stiffness times 1 + p_Dz dfz_i, 1 + q dfz_i (each >= 0.05), dfz_i = F_z,i / F_z0,i - 1, F_z,i = F_z,i,static
-+ m a_x h / L (h: cg_height or ``pitch_height``), F_z0,i the nominal car's static load.
"""

from __future__ import annotations

import numpy as np

from ..numerics.integrate import rk4_fixed_step_into
from ..settings import Vehicle
from .effects.terms import term_of
from .axle_loads import AxleLoads, SideSlip, course_sine, half_angle_sin_cos, yielded_front_slip
from .dynamics.rhs import Balance, slip_angles
from .single_track import VehicleParameters, tyre_angle

#: Newton steps of the loads-forces loop in :meth:`ExtendedSingleTrackRHS._forces`. From the steady
#: guess (its error is the transient m v beta_dot) two steps leave the yaw rate of a 0.6 g slalom
#: within 1.2e-5 of its range of the converged loop (three: 1e-8; none, the steady loads: 2e-2).
LOAD_NEWTON_STEPS = 2
#: The loop compiled (:mod:`uqdrive.vehicle.dynamics.load_newton`) where it can, the same numbers; False: NumPy's (the tests' reference).
COMPILED_LOOP = True
FUSED = True  # the compiled rates where they serve (False: the NumPy path, the reference of their tests)

__all__ = ["LOAD_NEWTON_STEPS", "ExtendedSingleTrackRHS", "chassis_rhs", "integrate_chassis"]


def _stiffness_factors(p: VehicleParameters) -> np.ndarray:
    """B_f and B_r (-): (2, 1) where the car has one tyre, (2, n) where the realisations of a pass
    of several tyre shapes each have their own (per-realisation ``c_Sf``, ``c_Sr``)."""
    if np.ndim(p.c_Sf) == 0 and np.ndim(p.c_Sr) == 0:
        return np.array([[p.c_Sf], [p.c_Sr]], float)
    return np.stack(np.broadcast_arrays(np.asarray(p.c_Sf, float), np.asarray(p.c_Sr, float)))


def _load_sensitive(s) -> bool:  # q or p_Dz of the load-sensitive tyre not 0
    return term_of("stiffness_load_sensitivity").active(s)


class ExtendedSingleTrackRHS(AxleLoads):
    """dx/dt of the single-track model with chassis effects, for n realisations.

    Parameters
    ----------
    p : VehicleParameters
        Per-realisation parameters (mu, l_f, m_load of shape (n,) or scalars).
    s : ModelStructure
        Structure; ``pitch_height`` (m), ``load_sensitivity`` (-), ``roll_share_front`` (-),
        ``compliance_steer`` (deg/g), ``relaxation_length`` (m), ``combined_slip`` (-),
        ``drive_share_front`` (-), ``course_weight``,
        ``lateral_acceleration`` (scalars or arrays (n,)).
    E : float or ndarray, shape (n,)
        Magic-Formula curvature factor (-).
    delta_half, F_w_half, yaw_gust, wind
        As :meth:`uqdrive.vehicle.dynamics.rhs.SingleTrackRHS.of_structure`.
    cg_height, track_width : float
        h and t (m) of the lateral load transfer (used only where ``load_sensitivity`` != 0).
    speed_half : tuple of two ndarrays, shape (J,), optional
        Speed v (m/s) and its rate v_dot (m/s^2) per half step; None: the held speed ``p.v_c``.
    reference_loads, tyre_load_height : tuple of two floats (or None: the static loads), float
        F_z0 (N) of the front and rear axle and the height h (m) of the load-sensitive tyre.
    """

    def __init__(self, p: VehicleParameters, s, E, delta_half, F_w_half, yaw_gust: bool, wind, cg_height: float = 0.0,
                 track_width: float = 1.0, speed_half=None, reference_loads=None, tyre_load_height: float = 0.0):
        self.v = v = float(p.v_c)
        self.balance = Balance(p)
        self.lever = np.stack(np.broadcast_arrays(self.balance.l_f, -p.l_r))
        self.m, self.L, self.g = p.m, p.wheelbase, p.g
        self.static = np.stack(np.broadcast_arrays(p.F_fz, p.F_rz))  # (2, n) static axle loads
        self.mu, self.B, self.C, self.E = p.mu, _stiffness_factors(p), p.C, E
        self.saturating = s.tyre == "magic_formula"
        self.course_sine = self.saturating or bool(s.course_exact)
        self.h_x = np.asarray(s.pitch_height, float)
        self.p_Dz = np.asarray(s.load_sensitivity, float)
        chi = np.asarray(s.roll_share_front, float)
        arm = np.stack(np.broadcast_arrays(chi, 1.0 - chi)) * (cg_height / track_width)
        self.lateral_arm = arm[:, None] if arm.ndim == 1 else arm  # (2, 1) or (2, n)
        self.kappa = np.deg2rad(np.asarray(s.compliance_steer, float)) / p.F_fz  # rad/N, (n,)
        self.compliant = bool(np.any(np.asarray(s.compliance_steer) != 0))
        self.sigma = np.asarray(s.relaxation_length, float)
        self.relaxed = bool(np.any(self.sigma > 0))
        self.rolling = bool(np.any(np.asarray(s.roll_steer) != 0))
        # rad per N of the tyres' force: the roll is the roll moment h T over the roll stiffness, a
        # constant of the car per newton, K per g at the base mass (not per g of each realisation's)
        self.roll_gain = np.deg2rad(np.asarray(s.roll_steer, float)) / (p.m_base * p.g)
        self.roll_omega = 2 * np.pi * np.asarray(s.roll_frequency, float)
        self.roll_zeta = np.asarray(s.roll_damping, float)
        self.i_roll = 6 if self.relaxed else 4
        self.pitching = bool(np.any(self.h_x != 0))
        self.transferring = bool(np.any(self.p_Dz != 0) or np.any(self.lateral_arm != 0))
        self.kappa_x = np.asarray(getattr(s, "combined_slip", 0.0), float)
        self.slipping = bool(np.any(self.kappa_x != 0))
        chi_d = np.asarray(getattr(s, "drive_share_front", 0.0), float)
        share = np.stack(np.broadcast_arrays(chi_d, 1.0 - chi_d))
        self.drive_share = share[:, None] if share.ndim == 1 else share  # (2, 1) or (2, n)
        self.brake_share = self.static / self.static.sum(axis=0)
        self.sensitive = _load_sensitive(s)  # q and p_Dz (1, n) or (1,); the reference F_z0 (2, 1) or (2, n)
        self.q_K, self.p_D = (np.asarray(getattr(s, f, 0.0), float)[None] for f in ("stiffness_load_sensitivity", "peak_load_sensitivity"))
        self.h_s, ref = np.where(self.h_x != 0, self.h_x, tyre_load_height), reference_loads
        self.reference = self.static if ref is None else np.asarray(ref, float).reshape(2, 1)
        self.loaded = self.pitching or bool(np.any(self.p_Dz != 0)) or self.slipping or self.sensitive
        self.k, self.a_v = s.course_weight, s.lateral_acceleration / v
        self.inv_mv = self.balance.mass_factor(p.m, v)
        self.delta_half, self.F_w_half = np.asarray(delta_half, float), F_w_half
        self.M_w = None if yaw_gust else p.M_c * np.asarray(wind, float)
        self.a_lat = s.lateral_acceleration
        self.speed_half = None if speed_half is None else tuple(np.asarray(a, float) for a in speed_half)
        self._last_delta = self._last_cos = None
        self._filled: dict = {}
        self._sigma_or_inf = np.where(self.sigma > 0, self.sigma, np.inf) if self.relaxed else None
        # the compiled loop where it is arithmetic alone: the linear tyre, or the Magic Formula at
        # slip angles the loads leave alone (not its load-sensitive stiffness, not yielding wheels)
        self._loop_compiles = self.loaded and COMPILED_LOOP and all(np.ndim(a) <= 1 for a in (p.c_Sf, p.c_Sr, self.C))
        self._compiled_loop = self._loop_compiles and not (self.saturating and (self.sensitive or self.compliant))
        self._constants, self._fused = None, None if FUSED else False  # the compiled rates, built at the first call

    def _at(self, j: int):
        """Speed v (m/s), its rate (m/s^2), 1 / (m v) and a_lat / v at half step ``j``."""
        if self.speed_half is None:
            return self.v, 0.0, self.inv_mv, self.a_v
        v = float(self.speed_half[0][j])
        return v, float(self.speed_half[1][j]), self.balance.mass_factor(self.m, v), self.a_lat / v

    @property
    def fused(self) -> bool:
        """Whether the rates run compiled (:mod:`uqdrive.vehicle.dynamics.fused_chassis`); known after the first call."""
        return bool(self._fused)

    @property
    def n_states(self) -> int:
        """4, plus the two lagged slip angles, plus the roll steer angle and its rate."""
        return 4 + 2 * self.relaxed + 2 * self.rolling

    def steady_slip(self, x, j: int, v=None, side_slip=None):
        """Slip angles (2, n) the tyres would have without relaxation and compliance, and the
        commanded front steer angle, at speed ``v`` (default: the speed at half step ``j``);
        ``side_slip``: x[2] with its sine and cosine where the caller has them."""
        psi_dot, beta = x[1], SideSlip.of(x[2] if side_slip is None else side_slip)
        v = self._at(j)[0] if v is None else v
        delta = self.delta_half[j]
        if self.saturating:
            return slip_angles(v, beta.sin, beta.cos, self.lever, psi_dot, delta), delta
        q = -(beta.beta + self.lever * psi_dot / v)  # the LST's small angles
        q[0] += delta
        return q, delta

    def tyre_forces(self, q, tyres, beta, v_dot=0.0, F_w=0.0):
        """Lateral axle forces (2, n) (N) at slip angles ``q`` (2, n) (rad), on the loads of
        :meth:`axle_loads` while the tyres carry ``tyres`` (n,) (N): Magic Formula or linear, as the
        structure's tyre."""
        return self._curve(self.axle_loads(tyres, beta, v_dot, F_w) * self.mu, q)

    def _curve(self, peak, q, B=None):
        """Force (N) at slip ``q`` (rad) and peak ``peak`` (N): Magic Formula or its slope at zero."""
        B = self.B if B is None else B
        if self.saturating:
            return peak * self._unit_curve(q, B)
        return peak * B * self.C * q

    def _unit_curve(self, q, B):
        """The Magic Formula per unit peak, sin(C atan(u)) (-), at slip ``q`` (rad): the factor of the peak that the loads leave alone."""
        return half_angle_sin_cos(tyre_angle(B * q, self.C, self.E))[0]

    def _load_free_curve(self, q_steady, lagged):
        """Per unit peak (2, n), the force of the slip angles that the loads-forces loop of :meth:`_forces` does not move, or None.

        On the Magic Formula a load scales the peak alone: the force of slip angles that do not
        depend on the loads is peak times this factor, computed once for the loop's steps (the
        same numbers: :meth:`_curve` multiplies the same factor). The lagged slip angles of a
        relaxing tyre are states; the steady ones move with the loads only where the wheels
        yield to their force (its front row then recomputed per step), and the load-sensitive
        tyre moves its stiffness with the load."""
        if not self.saturating or self.sensitive:
            return None
        return self._unit_curve(q_steady if lagged is None else lagged, self.B)

    def _at_loads(self, P, q_steady, delta, lagged, capacity=1.0, factors=None, unit=None):
        """Slip angles (2, n), front wheel angle (n,) and axle forces (2, n) on the effective loads
        ``P`` (2, n), each axle's peak times its lateral ``capacity`` (and the load-sensitive tyre's
        ``factors`` of :meth:`load_factors` on peak and stiffness): the force of the ``lagged``
        slip angles where the tyres relax (the wheels yield to it, which moves the slip's target),
        the front wheels yielding to their force where the steering is compliant. ``unit``: the
        force per unit peak of the slip angles the loads leave alone (:meth:`_load_free_curve`)."""
        peak = P * self.mu * capacity
        B = self.B
        if factors is not None:
            peak = peak * factors[0]
            B = B * (factors[1] / factors[0])
        q = q_steady.copy()
        if lagged is not None:
            F = self._curve(peak, lagged, B) if unit is None else peak * unit
            if self.compliant:
                q[0] -= self.kappa * F[0]
                delta = delta - self.kappa * F[0]
            return q, delta, F
        if self.compliant:
            q_front = yielded_front_slip(q[0], peak[0], B[0], self.C, self.E, self.kappa, self.saturating)
            delta = delta - (q[0] - q_front)
            q[0] = q_front
            if unit is not None:  # the rear's slip is the steady one: only the front's force is new
                F = np.empty_like(peak)
                F[0] = peak[0] * self._unit_curve(q_front, B[0])
                np.multiply(peak[1], unit[1], F[1])
                return q, delta, F
        return q, delta, self._curve(peak, q, B) if unit is None else peak * unit

    def _forces(self, x, j: int, v, v_dot, side_slip=None):
        """Steady slip angles (2, n), front wheel angle (n,) and axle forces (2, n) at ``x`` at speed ``v``
        changing at ``v_dot``.

        With load transfer the loads depend on the tyres' own lateral force T, which depends on the
        loads: T = F_f(P(T)) cos(delta) + F_r(P(T)) is solved by Newton's method from the steady
        T = m (v psi_dot cos(beta) + v' sin(beta) - a_lat) - F_w (``LOAD_NEWTON_STEPS`` steps; the
        slope neglects the compliant wheels' own loop beyond its linear part, which slows the
        convergence, not its limit)."""
        beta = SideSlip.of(x[2] if side_slip is None else side_slip)
        q_steady, delta = self.steady_slip(x, j, v, beta)
        if self.rolling:  # the roll steer angle, a state: no loop
            q_steady[0] -= x[self.i_roll]
            delta = delta - x[self.i_roll]
        lagged = np.where(self.sigma > 0, x[4:6], q_steady) if self.relaxed else None
        if not self.loaded:
            return self._at_loads(self.static, q_steady, delta, lagged)
        psi_dot = x[1]
        F_w = self.F_w_half[j]
        T = self.m * (v * psi_dot * beta.cos + v_dot * beta.sin - self.a_lat) - F_w
        unit = self._load_free_curve(q_steady, lagged)
        if self._compiled_loop:
            P, capacity, factors = self._newton_loads(T, beta, q_steady if lagged is None else lagged, unit, delta, F_w, v_dot)
            return self._at_loads(P, q_steady, delta, lagged, capacity if self.slipping else 1.0,
                                  (factors[:2], factors[2:]) if self.sensitive else None, unit)
        floor = 1e-3 * self.static
        trig = self._trig(beta)
        for _ in range(LOAD_NEWTON_STEPS):
            P, dP = self._loads(T, trig, v_dot, F_w, True)
            _, d, F = self._at_loads(P, q_steady, delta, lagged, self.lateral_capacity(T, beta, v_dot, F_w, P),
                                     self.load_factors(T, beta, v_dot, F_w), unit)
            dF = F / np.maximum(P, floor)
            if self.compliant and lagged is None:
                dF[0] /= 1.0 + self.kappa * P[0] * self.mu * self.B[0] * self.C
            front = self._cos_of(d) if self.saturating else 1.0
            gain = front * dF[0] * dP[0] + dF[1] * dP[1] if np.ndim(dP) else 0.0  # static loads (combined slip alone): none
            T = T + (front * F[0] + F[1] - T) / (self._at_least(1.0 - gain, 0.05) if np.ndim(gain) else max(1.0 - gain, 0.05))
        P = self._loads(T, trig, v_dot, F_w, False)
        return self._at_loads(P, q_steady, delta, lagged, self.lateral_capacity(T, beta, v_dot, F_w, P), self.load_factors(T, beta, v_dot, F_w), unit)

    def _newton_loads(self, T, beta, slip, unit, delta, F_w, v_dot):
        """The loop of :meth:`_forces` by :func:`uqdrive.vehicle.dynamics.load_newton.newton_loads` (its
        numbers): the loads (2, n), the lateral shares (2, n) and the load-sensitive tyre's factors
        (4, n) of the converged T, which ``T`` (n,) holds after it."""
        from .dynamics.jit import realisations
        from .dynamics.load_newton import newton_loads  # numba: only where a chassis model transfers load

        n = T.shape[0]
        full = lambda a: realisations(a, n)  # noqa: E731
        needs_trig = self.pitching or self.slipping or self.sensitive
        trig = np.stack([full(beta.tan), full(beta.cos), full(beta.sin)]) if needs_trig else np.zeros((3, n))
        front = full(self._cos_of(delta)) if self.saturating else np.ones(n)
        return newton_loads(T, self.load_constants(n), trig, front, np.ascontiguousarray(slip, float), np.zeros((0, n)) if unit is None else
                            np.ascontiguousarray(unit, float), full(F_w), LOAD_NEWTON_STEPS, v_dot, self.L, self.B[0], self.B[1], self.C,
                            pitching=self.pitching, transferring=self.transferring, slipping=self.slipping, sensitive=self.sensitive,
                            yielding=self.compliant and not self.relaxed)

    def lateral_acceleration(self, x, j: int):
        """a_y (m/s^2), shape (n,), of ``x`` (n_states, n) at half step ``j``: the specific force
        an accelerometer at the centre of gravity reads, (F_f cos delta + F_r + F_w) / m, with the
        lagged slip angles where the tyres relax (uqdrive.vehicle.track_rk4's a_y convention); the
        compiled rates' sum of the forces where they serve (the same numbers; at 300 realisations
        half the time of the NumPy loads and forces, at 2400 about 10 % less)."""
        if self._fused_rates(x, j, np.empty_like(x)):
            return self._fused.total / self.m
        _, delta, F = self._forces(x, j, *self._at(j)[:2])
        return (self._front(F[0], delta) + F[1] + self.F_w_half[j]) / self.m

    def _front(self, F_f, delta):
        """The front axle's force across the car: F_f cos delta (NLST), F_f (LST)."""
        return F_f * self._cos_of(delta) if self.saturating else F_f

    def _cos_of(self, delta):
        """cos(delta) (n,), of the last wheel angle asked for kept: the loads' loop and the
        derivative ask for the same array while the wheels do not yield to their force."""
        if np.ndim(delta) == 0:
            return np.cos(delta)
        if delta is not self._last_delta:
            self._last_delta, self._last_cos = delta, half_angle_sin_cos(delta)[1]
        return self._last_cos

    def _fused_rates(self, x, j: int, out) -> bool:
        """dx/dt into ``out`` by the compiled rates (built at the first call) where they serve, and True; else False."""
        if self._fused is None:
            from .dynamics import fused_chassis, fused_linear  # numba: only where a chassis model is integrated

            build = fused_chassis.fused_chassis_rates if self.saturating else fused_linear.fused_linear_chassis_rates
            self._fused = build(self, x, LOAD_NEWTON_STEPS, self._loop_compiles) or False  # the compiled rates step the sensitive tyre's loop
        if not self._fused:
            return False
        delta = self.delta_half[j]
        cos_delta = np.cos(delta) if self.saturating and np.ndim(delta) == 0 else None
        self._fused(x, out, delta, cos_delta, self.F_w_half[j], self.M_w, *self._at(j), self.speed_half is not None)
        return True

    def __call__(self, x, j: int, out) -> None:
        """dx/dt (n_states, n) of ``x`` at half step ``j`` into ``out``."""
        if self._fused_rates(x, j, out):
            return
        psi, psi_dot, beta = x[0], x[1], x[2]
        side_slip = SideSlip(beta)
        v, v_dot, inv_mv, a_v = self._at(j)
        q, delta, F = self._forces(x, j, v, v_dot, side_slip)
        cos_b = side_slip.cos if self.saturating else 1.0
        if self.relaxed:
            out[4:6] = (q - x[4:6]) * (v * cos_b) / self._sigma_or_inf
        F_w = self.F_w_half[j]
        fc = self._front(F[0], delta)
        if self.rolling:  # the roll mode, and the steer it makes, driven by the tyres' lateral force
            w, eps, rate = self.roll_omega, x[self.i_roll], x[self.i_roll + 1]
            out[self.i_roll] = rate
            out[self.i_roll + 1] = w * w * (self.roll_gain * (fc + F[1]) - eps) - 2.0 * self.roll_zeta * w * rate
        out[0] = psi_dot
        self.balance.rates(fc, F[1], F_w, self.M_w, psi_dot, cos_b if self.saturating else None, inv_mv, out[1], out[2], np.empty_like(psi_dot))
        out[2] += a_v
        if self.speed_half is not None:
            out[2] -= v_dot / v * (side_slip.sin if self.saturating else beta)
        course = psi + self.k * beta
        out[3] = v * (course_sine(course) if self.course_sine else course)


def chassis_rhs(vehicle: Vehicle, p: VehicleParameters, s, E, delta_half, F_w_half, yaw_gust: bool, wind, speed_half=None,
                reference_loads=None) -> ExtendedSingleTrackRHS:
    """The right-hand side :func:`integrate_chassis` integrates, with the car's cg_height and
    track_width where the terms need them (an error naming the effect where the car lacks one)."""
    h_t = (0.0, 1.0)
    if np.any(np.asarray(s.load_sensitivity) != 0):
        purpose = "the effect lateral_load_transfer"
        h_t = (vehicle.require("cg_height", purpose), vehicle.require("track_width", purpose))
    h_s = vehicle.require("cg_height", "the effect load_sensitive_tyre") if _load_sensitive(s) else 0.0
    return ExtendedSingleTrackRHS(p, s, E, delta_half, F_w_half, yaw_gust, wind, *h_t, speed_half=speed_half, reference_loads=reference_loads,
                                  tyre_load_height=h_s)


def integrate_chassis(vehicle: Vehicle, p: VehicleParameters, s, E, delta_half, F_w_half, yaw_gust: bool, wind, h: float,
                      n_steps: int, record_every: int, with_rhs: bool = False, speed_half=None, reference_loads=None):
    """States (4, n, K + 1) (a time-major view) of the model with chassis effects from rest by
    RK4; arguments as :func:`uqdrive.vehicle.track_rk4.integrate_single_track` (``speed_half`` its
    speed profile), the car and the load-sensitive tyre's F_z0 ``reference_loads`` as :func:`chassis_rhs`.
    With ``with_rhs``: every state (n_states, n, K + 1) and the right-hand side (a_y from them)."""
    rhs = chassis_rhs(vehicle, p, s, E, delta_half, F_w_half, yaw_gust, wind, speed_half, reference_loads)
    step = rk4_fixed_step_into
    if FUSED:  # the stepper's arithmetic compiled too, the same numbers
        from .dynamics.fused_rk4 import rk4_fused_into as step
    out = step(rhs, np.zeros((rhs.n_states, np.size(wind))), h, n_steps, record_every)
    if with_rhs:
        return out.transpose(1, 2, 0), rhs
    return out[:, :4].transpose(1, 2, 0)

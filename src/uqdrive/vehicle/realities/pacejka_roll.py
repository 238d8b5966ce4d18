"""A multi-body-like reality: the Pacejka single-track car with a body roll mode whose camber moves
both axles' slip, and tyres whose slip angles relax, integrated by the same RK4 as the plain car.

Besides :mod:`.pacejka_single_track`'s equations, with the roll angle phi positive leaning out of a
left turn (Pacejka, *Tyre and Vehicle Dynamics*, (7.9) for the relaxation; Milliken and Milliken,
*Race Car Vehicle Dynamics*, ch. 17, for the roll gradient)::

    alpha_i,lag' = (v_x / sigma) (alpha_i - alpha_i,lag)             (the tyre's relaxation length sigma)
    phi''        = omega^2 (R_phi a_y / g - phi) - 2 zeta omega phi'  (roll gradient R_phi per g, omega = 2 pi f)
    alpha_i,tyre = alpha_i,lag - epsilon_i phi                        (camber thrust as the slip it equals)

alpha_i the kinematic slip angles and a_y the lateral specific force at the centre of gravity; the
tyres' forces follow alpha_i,tyre. The front axle's camber slip is a steer angle -epsilon_f phi
(a roll steer); the rear's has no steer to act through.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .pacejka_single_track import STATE_ROWS, PacejkaCar, PacejkaRHS

__all__ = ["RollingCar", "RollingRHS", "ROLLING_ROWS"]

#: State rows: the plain car's, the lagged front and rear slip angles, the roll angle and its rate.
ROLLING_ROWS = STATE_ROWS + ("alpha_f", "alpha_r", "phi", "phi_dot")


@dataclass(frozen=True)
class RollingCar(PacejkaCar):
    """:class:`PacejkaCar` with a roll mode, roll camber and relaxing tyres (SI units).

    Attributes
    ----------
    relaxation_length : float
        sigma (m) of both axles' tyres, > 0.
    roll_gradient : float
        R_phi (rad per g of lateral acceleration): the steady roll angle.
    roll_frequency, roll_damping : float
        f (Hz) and zeta (-) of the roll mode.
    camber_slip_front, camber_slip_rear : float
        epsilon_i (rad of slip per rad of roll): the camber gain times the camber over the
        cornering stiffness of the axle's tyres, plus the axle's kinematic roll steer (its toe
        change per rad of roll, positive out of the turn), which moves the slip the same way.
    """

    relaxation_length: float = 0.6
    roll_gradient: float = float(np.deg2rad(6.0))
    roll_frequency: float = 1.4
    roll_damping: float = 0.35
    camber_slip_front: float = 0.12
    camber_slip_rear: float = 0.10

    def right_hand_side(self, *args) -> "RollingRHS":
        """The car's :class:`RollingRHS` of ``args`` (:class:`PacejkaRHS`'s after the car)."""
        return RollingRHS(self, *args)


class RollingRHS(PacejkaRHS):
    """dx/dt (12, n) of :class:`RollingCar`: the rows of :data:`ROLLING_ROWS` (arguments as :class:`PacejkaRHS`)."""

    n_states = len(ROLLING_ROWS)

    def slip_angles(self, x, kinematic):
        """The lagged slip angles x[8:10] less the camber slip epsilon_i phi (2, n) (rad)."""
        c = self.car
        return x[8:10] - np.array([[c.camber_slip_front], [c.camber_slip_rear]]) * x[10]

    def derivatives(self, x, j, F_x, F_y, F_z, kappa, alpha, delta):
        """The plain car's rates and those of the lagged slip angles and the roll (12, n)."""
        c = self.car
        out = super().derivatives(x, j, F_x, F_y, F_z, kappa, alpha, delta)
        out[8:10] = x[2] / c.relaxation_length * (self.kinematic_slip(x, delta) - x[8:10])
        a_y = (F_x[0] * np.sin(delta) + F_y[0] * np.cos(delta) + F_y[1] + self.F_w(j)) / self.m
        omega = 2.0 * np.pi * c.roll_frequency
        out[10] = x[11]
        out[11] = omega * omega * (c.roll_gradient * a_y / c.g - x[10]) - 2.0 * c.roll_damping * omega * x[11]
        return out

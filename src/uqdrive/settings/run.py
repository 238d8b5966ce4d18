"""The settings of a run as typed objects: the time grid, the speed, the wind and its KLE, the
steering, the spin policy, and the settings of identify, discover, the controller and the quarter car."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, Mapping

import numpy as np

from ..config import ConfigError
from .car import metres_per_second

__all__ = ["TimeGrid", "SpeedRamp", "Wind", "Steering", "Spin", "Identify", "Discover", "model_realisations", "Control", "WheelSlipCar"]


@dataclass(frozen=True)
class TimeGrid:
    """Output grid t_k = k dt on [0, t_end] and the fine integration step h = dt / substeps (s)."""

    t_end: float
    dt: float
    step: float

    def __post_init__(self):
        for name in ("t_end", "dt", "step"):
            value = getattr(self, name)
            if value is not None and not value > 0:
                raise ConfigError(f"time grid: {name} = {value} s must be positive")

    @property
    def n_out(self) -> int:
        """Number of output intervals, t_end / dt."""
        return int(round(self.t_end / self.dt))

    @property
    def substeps(self) -> int:
        """Integration steps per output interval, dt / step."""
        return int(round(self.dt / self.step))

    @property
    def output(self) -> np.ndarray:
        """Output times, shape (n_out + 1,) (s)."""
        return np.arange(self.n_out + 1) * self.dt

    def fine(self, refine: int = 1) -> np.ndarray:
        """Fine grid with step h / refine (refine=2 gives the RK4 half-step grid)."""
        n = self.n_out * self.substeps * refine
        return np.arange(n + 1) * (self.step / refine)


@dataclass(frozen=True)
class SpeedRamp:
    """A linear speed change from ``start_kmh`` to ``end_kmh`` (km/h) over ``duration`` s from ``t_start`` s."""

    start_kmh: float
    end_kmh: float
    duration: float
    t_start: float = 0.0

    def on(self, t) -> np.ndarray:
        """v(t) (m/s) at the times ``t`` (s), same shape: constant before and after the change."""
        s = np.clip((np.asarray(t, float) - self.t_start) / self.duration, 0.0, 1.0)
        return metres_per_second(self.start_kmh + (self.end_kmh - self.start_kmh) * s)


@dataclass(frozen=True)
class Wind:
    """The side wind (5.1)-(5.2) and its KLE settings (5.16)-(5.22): sigma (N), Tc (s), the
    Gauss-Legendre points and the truncation p_c, and whether the gusts exert the yaw moment M_c F_w."""

    sigma: float
    Tc: float
    kle_quadrature: int
    kle_truncation: float
    gust_yaw_moment: bool = True


@dataclass(frozen=True)
class Steering:
    """The sine steering (5.5)/(5.7): amplitude (deg) and period (s)."""

    delta_max_deg: float
    period: float

    @property
    def delta_max(self) -> float:
        """The amplitude in rad."""
        return np.deg2rad(self.delta_max_deg)


@dataclass(frozen=True)
class Spin:
    """A realisation with |beta| above ``threshold`` (rad) lost control; ``policy`` keep | exclude."""

    threshold: float
    policy: str = "exclude"


@dataclass(frozen=True)
class Identify:
    """The identification's settings (sec. 5.3.2): PCE order and Gauss points, iterations, state scales, optimiser."""

    order: int = 2
    quadrature_points: int = 4
    max_iter: int = 300
    state_scale: str = "none"
    normalised_state_scale: str = "rms_mean"
    optimiser: str = "lbfgsb"

    def scale(self, normalised: bool = False) -> str:
        """The state scale of the thesis-faithful fit, or of the normalised one."""
        return self.normalised_state_scale if normalised else self.state_scale


@dataclass(frozen=True)
class Discover:
    """The discrepancy search's settings (``discrepancy`` section): candidates, ensemble sizes
    (``model_ratio``: linear-model realisations per measured run, 0 for ``model_samples`` always),
    bootstrap, level, compared times, screened and added effects, and the posterior's settings."""

    candidates: tuple | None = None
    model_samples: int = 1000
    nonlinear_samples: int = 300
    model_ratio: float = 0.0
    bootstrap: int = 200
    level: float = 0.01
    max_times: int = 150
    top: int = 3
    max_effects: int = 3
    posterior_enabled: bool = False
    posterior_effects: tuple = ()
    posterior: Mapping[str, Any] = field(default_factory=lambda: MappingProxyType({}))

    @classmethod
    def from_section(cls, d: Mapping[str, Any]) -> "Discover":
        """The settings of a config's ``discrepancy`` section (missing keys take the defaults)."""
        p = dict(d.get("posterior", {}))
        fields = {k: d[k] for k in ("model_samples", "nonlinear_samples", "model_ratio", "bootstrap", "level", "max_times", "top", "max_effects") if k in d}
        c = d.get("candidates")
        return cls(candidates=None if c is None else (c,) if isinstance(c, str) else tuple(c), **fields,
                   posterior_enabled=bool(p.get("enabled", False)), posterior_effects=tuple(p.get("effects") or ()),
                   posterior=MappingProxyType({k: v for k, v in p.items() if k not in ("enabled", "effects")}))

    def wants_posterior(self, effect: str) -> bool:
        """Whether the posterior of a verdict naming ``effect`` is sampled."""
        return self.posterior_enabled and (not self.posterior_effects or effect in self.posterior_effects)


def model_realisations(runs: int, model_samples: int, nonlinear_samples: int, model_ratio: float) -> int:
    """Common-random-number realisations of the linear models for ``runs`` measured runs.

    M = min(model_samples, max(nonlinear_samples, ceil(model_ratio * runs))), or ``model_samples``
    when ``model_ratio`` is 0. The comparison's scale carries the model's sampling as the factor
    sqrt(1 + runs / M), so M >= model_ratio * runs keeps the model's share of the variance at most
    1 / model_ratio of the data's; the floor keeps the raw germs the non-linear models take
    (``nonlinear_samples`` of the same draw).

    Parameters
    ----------
    runs : int
        Measured runs compared (those the spin policy leaves out not counted).
    model_samples, nonlinear_samples : int
        The cap, and the floor when ``model_ratio`` > 0.
    model_ratio : float
        Realisations per measured run; 0 for ``model_samples`` whatever ``runs``.

    Returns
    -------
    int
        M.
    """
    if model_ratio <= 0:
        return int(model_samples)
    wanted = math.ceil(round(model_ratio * runs, 9))  # 0.7 * 10 is 7.000000000000001, not 8 realisations' worth
    return int(min(model_samples, max(nonlinear_samples, wanted)))


@dataclass(frozen=True)
class Control:
    """The lane-keeping controller's case (6.1), (5.35)-(5.38): initial offset range y0 (m), yaw
    psi0 (deg), horizon T (s), the mean/variance split gamma and the LQR weights."""

    y0: tuple = (0.0, 1.75)
    psi0_deg: float = 5.0
    horizon: float = 2.0
    gamma: float = 0.001
    Q_diag: tuple = (1.0, 1.0, 1.0, 10.0)
    R: float = 100.0


@dataclass(frozen=True)
class WheelSlipCar:
    """The quarter car of the wheel-slip controller (GP paper, sec. III): wheel radius r (m),
    load F_z (N), mass (kg), wheel inertia J (kg m^2), actuator time constant T_a (s), curve
    slope k, peak friction mu_H, slip set-point, damping and natural frequency (rad/s)."""

    r: float = 0.35
    F_z: float = 2452.5
    mass: float = 250.0
    J: float = 0.68
    T_a: float = 0.014
    k: float = 28.0
    mu_H: float = 0.9
    lambda_star: float = 0.15
    zeta_d: float = 0.5
    omega_0d: float = 20 * np.pi

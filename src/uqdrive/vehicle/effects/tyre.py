"""The load-sensitive tyre as a candidate effect: cornering stiffness and peak that depart from
proportionality to the axle load as the longitudinal load transfer moves it (Pacejka's K_y(F_z)).
"""

from __future__ import annotations

from dataclasses import replace

from .structure import Effect

__all__ = ["LoadSensitiveTyre"]


class LoadSensitiveTyre(Effect):
    """Axle i's cornering stiffness mu F_z,i B C (1 + q dfz_i) and peak mu F_z,i (1 + p_Dz dfz_i),
    dfz_i = (F_z,i - F_z0,i) / F_z0,i the load the longitudinal acceleration moves at the car's
    centre-of-gravity height (Pacejka, *Tyre and Vehicle Dynamics*, (4.E13) and the linear part of
    (4.E25)); q = p_Dz = 0: the baseline's tyre."""

    def apply(self, s, v):
        """``s`` with q = ``v[0]`` and p_Dz = ``v[1]`` (both -)."""
        return replace(s, stiffness_load_sensitivity=float(v[0]), peak_load_sensitivity=float(v[1]))

"""The tyre's candidate effects beyond the saturation: cornering stiffness and peak that depart from
proportionality to the axle load (Pacejka's K_y(F_z)), and the tyre's own Magic-Formula shape.
"""

from __future__ import annotations

from dataclasses import replace

from ..single_track import VehicleParameters
from .structure import Effect, ModelStructure

__all__ = ["LoadSensitiveTyre", "TyreShape", "with_tyre_shape", "shape_parts"]


class LoadSensitiveTyre(Effect):
    """Axle i's cornering stiffness mu F_z,i B C (1 + q dfz_i) and peak mu F_z,i (1 + p_Dz dfz_i),
    dfz_i = (F_z,i - F_z0,i) / F_z0,i the load the longitudinal acceleration moves at the car's
    centre-of-gravity height (Pacejka, *Tyre and Vehicle Dynamics*, (4.E13) and the linear part of
    (4.E25)); q = p_Dz = 0: the baseline's tyre."""

    vanishes = ("q", 0.0)

    def apply(self, s, v):
        """``s`` with q = ``v[0]`` and p_Dz = ``v[1]`` (both -)."""
        return replace(s, stiffness_load_sensitivity=float(v[0]), peak_load_sensitivity=float(v[1]))


class TyreShape(Effect):
    """The tyre's own Magic-Formula shape where the car's constants have the wrong one: axle i's force

        F_i = mu F_z,i sin(C atan(b B_i alpha_i - E (b B_i alpha_i - atan(b B_i alpha_i))))

    ((2.2); Pacejka, *Tyre and Vehicle Dynamics*, (4.E19) without shifts), B_i the car's B_f or B_r,
    fitted jointly with the distributions (mu's among them): b (-) scales both axles' stiffness
    factors, C (-) and E (-) replace the car's. The cornering stiffness b B_i C mu F_z,i moves with
    b and C; C also sets the force past the peak (sin(C pi / 2) of the peak as alpha grows), E the
    curvature at the peak. b = 1 with the car's C: :class:`TyreSaturation` at E."""

    def apply(self, s, v):
        """``s`` with the Magic Formula, b = ``v[0]``, C = ``v[1]`` and E = ``v[2]`` (all -)."""
        return replace(s, tyre="magic_formula", tyre_stiffness_factor=float(v[0]), tyre_shape_factor=float(v[1]), tyre_curvature=float(v[2]))


def with_tyre_shape(p: VehicleParameters, s: ModelStructure) -> VehicleParameters:
    """``p`` with the structure's tyre shape (:class:`TyreShape`): B_f and B_r times b, C replaced; ``p`` itself without one."""
    b, C = s.tyre_shape()
    if b == 1.0 and C is None:
        return p
    return replace(p, c_Sf=p.c_Sf * b, c_Sr=p.c_Sr * b, C=p.C if C is None else C)


def shape_parts(structures, groups=None) -> list:
    """Indices of ``structures`` by group (``groups``: sizes of consecutive runs of them; None: one)
    and within a group by tyre shape (:meth:`ModelStructure.tyre_shape`), a group's shapes in order of first use."""
    parts, start = [], 0
    for size in groups or [len(structures)]:
        shapes: dict = {}
        for i in range(start, start + size):
            shapes.setdefault(structures[i].tyre_shape(), []).append(i)
        parts += shapes.values()
        start += size
    return parts

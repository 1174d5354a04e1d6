"""Gravity: force ``-mass g`` at the centre of mass (g = 1)."""

import taichi as ti

from ..columns import Body, Param
from .base import Effect


@ti.func
def force(a: ti.template(), i):
    return ti.Vector([-a.b[i, Body.MASS], 0.0])


@ti.func
def potential(a: ti.template(), i):
    """``m g (z_G - water_level)``: measured from the sea surface (docs/model.md)."""
    return a.b[i, Body.MASS] * (a.b[i, Body.Z] - a.par[Param.WATER])


EFFECT = Effect(name="gravity", doc="force -mass * g at the centre of mass", force=force, potential=potential)

"""The ``@ti.func`` terms of the gravity effect (declared, with its physics, in :mod:`..gravity`)."""

import taichi as ti

from ...data.schema import Body, Param


@ti.func
def force(a: ti.template(), i):
    return ti.Vector([0.0, -a.b[i, Body.MASS], 0.0])


@ti.func
def potential(a: ti.template(), i):
    """``m g (z_G - water_level)``: measured from the sea surface (docs/model.md)."""
    return a.b[i, Body.MASS] * (a.b[i, Body.Z] - a.par[Param.WATER])

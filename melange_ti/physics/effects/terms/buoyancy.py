"""The ``@ti.func`` terms of the buoyancy effect (declared, with its physics, in :mod:`..buoyancy`)."""

import taichi as ti

from ...data.schema import Body, Param
from ...shape.hydrostatics import divisors, submerged_moments


@ti.func
def _moments(a: ti.template(), i):
    six, _ = divisors(a.par)
    return submerged_moments(a, i, a.par[Param.WATER], six)


@ti.func
def force(a: ti.template(), i):
    """``rho_w g A`` upward at the submerged centroid: force ``A``, torque ``Sx`` about the
    centre of mass (g = rho_w = 1)."""
    mo = _moments(a, i)
    return ti.Vector([0.0, mo[0], mo[1]])


@ti.func
def potential(a: ti.template(), i):
    """``-rho_w g int_sub (z - water_level) dA``."""
    mo = _moments(a, i)
    return -(mo[2] + mo[0] * (a.b[i, Body.Z] - a.par[Param.WATER]))

"""The ``@ti.func`` terms of the drag effect (declared, with its physics, in :mod:`..drag`)."""

import taichi as ti

from ...data.schema import Body, Param


@ti.func
def damp(a: ti.template(), i, m, inertia):
    """``m``, ``inertia``: the iceberg's, with the water's added inertia when that effect is
    on (the energy of both is what the drag removes)."""
    b = ti.static(a.b)
    dt = a.par[Param.DT]
    vx, vz, om = b[i, Body.VX], b[i, Body.VZ], b[i, Body.OM]
    lin = 1.0 / (1.0 + a.par[Param.DRAG_LIN] * dt)
    ang = 1.0 / (1.0 + a.par[Param.DRAG_ANG] * dt)
    b[i, Body.VX] = vx * lin
    b[i, Body.VZ] = vz * lin
    b[i, Body.OM] = om * ang
    b[i, Body.DRAG_WORK] += 0.5 * m * (vx * vx + vz * vz) * (1.0 - lin * lin) + 0.5 * inertia * om * om * (1.0 - ang * ang)

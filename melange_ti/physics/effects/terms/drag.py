"""The ``@ti.func`` terms of the drag effect (declared, with its physics, in :mod:`..drag`)."""

import taichi as ti

from ...data.schema import Body, Param


@ti.func
def lost(m, inertia, vx, vz, om, nvx, nvz, nom):
    """The kinetic energy a change of the velocities ``v -> v'`` removes, as the velocities
    stored have it: ``m (v - v') . (v + v') / 2`` (and the rotation's), to a few ulps (``v - v'``
    is exact when the change is small). Written ``1/2 m v^2 (1 - keep^2)`` it lost ``eps / 2x``
    of its digits for a decay ``keep = 1 / (1 + x)`` (``x = c dt``, 1e-4 at the paper's drag and
    step: 3e-4 of drag_dissipated in f32), and measured the decay as it should be, not as the
    stored velocities, rounded, took it."""
    return 0.5 * m * ((vx - nvx) * (vx + nvx) + (vz - nvz) * (vz + nvz)) + 0.5 * inertia * (om - nom) * (om + nom)


@ti.func
def damp(a: ti.template(), i, m, inertia):
    """``m``, ``inertia``: the iceberg's, with the water's added inertia when that effect is
    on (the energy of both is what the drag removes)."""
    b = ti.static(a.b)
    dt = a.par[Param.DT]
    vx, vz, om = b[i, Body.VX], b[i, Body.VZ], b[i, Body.OM]
    lin = 1.0 / (1.0 + a.par[Param.DRAG_LIN] * dt)
    ang = 1.0 / (1.0 + a.par[Param.DRAG_ANG] * dt)
    nvx, nvz, nom = vx * lin, vz * lin, om * ang
    b[i, Body.VX] = nvx
    b[i, Body.VZ] = nvz
    b[i, Body.OM] = nom
    b[i, Body.DRAG_WORK] += lost(m, inertia, vx, vz, om, nvx, nvz, nom)

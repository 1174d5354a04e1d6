"""The ``@ti.func`` terms of the form_drag effect (declared, with its physics, in :mod:`..form_drag`)."""

import taichi as ti

from ...data.schema import Body, Param
from ...shape.hydrostatics import divisors, wetted


@ti.func
def damp(a: ti.template(), i, m, inertia):
    b = ti.static(a.b)
    dt = a.par[Param.DT]
    vx, vz, om = b[i, Body.VX], b[i, Body.VZ], b[i, Body.OM]
    speed = ti.sqrt(vx * vx + vz * vz)
    ux, uz = 1.0, 0.0  # the direction normal to v (any, at rest)
    if speed > 0:
        ux, uz = -vz / speed, vx / speed
    six, twelve = divisors(a.par)
    w = wetted(a, i, a.par[Param.WATER], ux, uz, six, twelve)
    half_cd = 0.5 * a.par[Param.FORM_DRAG]
    lin = 1.0 / (1.0 + half_cd * w[2] / m * speed * dt)
    ang = 1.0 / (1.0 + half_cd * w[3] / inertia * ti.abs(om) * dt)
    b[i, Body.VX] = vx * lin
    b[i, Body.VZ] = vz * lin
    b[i, Body.OM] = om * ang
    b[i, Body.DRAG_WORK] += 0.5 * m * speed * speed * (1.0 - lin * lin) + 0.5 * inertia * om * om * (1.0 - ang * ang)

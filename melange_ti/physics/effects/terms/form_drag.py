"""The ``@ti.func`` terms of the form_drag effect (declared, with its physics, in :mod:`..form_drag`)."""

import taichi as ti

from ...data.schema import Body, Param
from ...shape.hydrostatics import divisors, wetted
from .drag import lost


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
    nvx, nvz, nom = vx * lin, vz * lin, om * ang
    b[i, Body.VX] = nvx
    b[i, Body.VZ] = nvz
    b[i, Body.OM] = nom
    b[i, Body.DRAG_WORK] += lost(m, inertia, vx, vz, om, nvx, nvz, nom)

"""The ``@ti.func`` terms of the added_mass effect (declared, with its physics, in :mod:`..added_mass`)."""

import taichi as ti

from ...data.schema import Body, Param
from ...shape.hydrostatics import divisors, wetted


@ti.func
def _added(a: ti.template(), i):
    six, twelve = divisors(a.par)
    w = wetted(a, i, a.par[Param.WATER], 1.0, 0.0, six, twelve)
    return ti.Vector([a.par[Param.ADDED_MASS] * w[0], a.par[Param.ADDED_INERTIA] * w[1]])


@ti.func
def added_inertia(a: ti.template(), i):
    """m_a, I_a at the current pose; kept for the rest of the step (contacts, correction)."""
    extra = _added(a, i)
    a.b[i, Body.ADDED_M] = extra[0]
    a.b[i, Body.ADDED_I] = extra[1]
    return extra


@ti.func
def post_drift(a: ti.template(), i):
    """Book the energy exchanged as m_a and I_a changed over the step."""
    b = ti.static(a.b)
    now = _added(a, i)
    v2 = b[i, Body.VX] ** 2 + b[i, Body.VZ] ** 2
    om2 = b[i, Body.OM] ** 2
    b[i, Body.ADDED_WORK] -= 0.5 * (now[0] - b[i, Body.ADDED_M]) * v2 + 0.5 * (now[1] - b[i, Body.ADDED_I]) * om2

"""Linear drag (the paper's): ``dv/dt = -drag v``, ``domega/dt = -angular_drag omega``.

Applied after the forces as ``v /= (1 + c dt)`` (backward Euler for the drag term:
unconditionally stable, never reverses a velocity); the exact kinetic energy it removes is
booked per body in the ``DRAG_WORK`` ledger (``drag_dissipated``).
"""

import taichi as ti

from ..columns import Body, Column, Param
from .base import Effect, Key

E = "rho_w g w^3"


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


EFFECT = Effect(
    name="drag",
    doc="linear damping of velocity and angular velocity at the given rates",
    keys=(
        Key(
            "drag",
            0.01,
            "1 / sqrt(w/g)",
            "rate of linear drag on (vx, vz): dv/dt = -drag v (the paper's 0.01)",
            lambda v: v >= 0.0,
            "must be >= 0",
        ),
        Key(
            "angular_drag",
            0.01,
            "1 / sqrt(w/g)",
            "rate of linear drag on omega: domega/dt = -angular_drag omega",
            lambda v: v >= 0.0,
            "must be >= 0",
        ),
    ),
    params=(
        Column("DRAG_LIN", "constant", "1 / sqrt(w/g)", "linear drag rate", source="physics.drag"),
        Column("DRAG_ANG", "constant", "1 / sqrt(w/g)", "angular drag rate", source="physics.angular_drag"),
    ),
    body_columns=(Column("DRAG_WORK", "ledger", E, "energy removed by drag since t = 0", "drag_dissipated"),),
    damp=damp,
)

"""Linear drag (the paper's): ``dv/dt = -drag v``, ``domega/dt = -angular_drag omega``.

Applied after the forces as ``v /= (1 + c dt)`` (backward Euler for the drag term:
unconditionally stable, never reverses a velocity); the exact kinetic energy it removes is
booked per body in the ``DRAG_WORK`` ledger (``drag_dissipated``).
"""

from ..data.columns import Column, E
from .base import Effect, Key

EFFECT = Effect(
    name="drag",
    doc="linear damping of velocity and angular velocity at the given rates",
    keys=(
        Key.nonnegative("drag", 0.01, "1 / sqrt(w/g)", "rate of linear drag on (vx, vz): dv/dt = -drag v (the paper's 0.01)"),
        Key.nonnegative("angular_drag", 0.01, "1 / sqrt(w/g)", "rate of linear drag on omega: domega/dt = -angular_drag omega"),
    ),
    params=(
        Column("DRAG_LIN", "constant", "1 / sqrt(w/g)", "linear drag rate", source="physics.drag"),
        Column("DRAG_ANG", "constant", "1 / sqrt(w/g)", "angular drag rate", source="physics.angular_drag"),
    ),
    body_columns=(Column("DRAG_WORK", "ledger", E, "energy removed by drag since t = 0", "drag_dissipated", budget=True),),
    terms=("damp",),
)

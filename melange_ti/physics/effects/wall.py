"""The wall: a rigid, immovable vertical wall at ``x = wall_x`` that icebergs collide with
(the contact law of :mod:`..step.impulses` with infinite mass; normal +x).

Its contact is found here (:func:`detect`), one per iceberg, from the discs within reach;
the impulse pass and the correction visit it before the body's partners."""

from ..data.columns import Column
from .base import Effect, Key

EFFECT = Effect(
    name="wall",
    doc="a rigid, immovable vertical wall at x = wall_x (same impulse law, infinite mass)",
    keys=(Key("wall_x", 0.0, "w", "x of the rigid wall", None, ""),),
    params=(Column("WALL_X", "constant", "w", "x of the wall", source="physics.wall_x"),),
    body_columns=(
        Column("WALL_PZ", "scratch", "w", "wall contact: height of the contact point"),
        Column("WALL_GAP", "scratch", "w", "wall contact: gap when found"),
    ),
)

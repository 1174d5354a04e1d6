"""Buoyancy: the exact hydrostatic force and torque of the submerged part (:mod:`..shape.hydrostatics`)."""

from .base import Effect

EFFECT = Effect(
    name="buoyancy",
    doc="exact hydrostatic force and torque of the submerged part of the outline (rectangle or polygon) under a flat sea surface",
    torque=True,
    terms=("force", "potential"),
)

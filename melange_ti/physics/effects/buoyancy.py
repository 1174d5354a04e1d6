"""Buoyancy: the exact hydrostatic force and torque of the submerged part (:mod:`..hydrostatics`)."""

from .base import Effect

EFFECT = Effect(
    name="buoyancy",
    doc="exact hydrostatic force and torque of the submerged part of the rectangle under a flat sea surface",
    torque=True,
    terms=("force", "potential"),
)

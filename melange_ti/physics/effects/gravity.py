"""Gravity: force ``-mass g`` at the centre of mass (g = 1)."""

from .base import Effect

EFFECT = Effect(name="gravity", doc="force -mass * g at the centre of mass", terms=("force", "potential"))

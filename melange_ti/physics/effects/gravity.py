"""Gravity: force ``-mass g`` at the centre of mass (g = 1)."""

from .base import Effect


def _kernels():
    from .terms import gravity

    return gravity


EFFECT = Effect(name="gravity", kernels=_kernels, doc="force -mass * g at the centre of mass", terms=("force", "potential"))

"""The ``@ti.func`` terms of the waves effect (declared, with its physics, in :mod:`..effects.waves`;
the grid's kernels are in :mod:`..waves`)."""

from ..waves import deposit as post_drift
from ..waves import force

__all__ = ["force", "post_drift"]

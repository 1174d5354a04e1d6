"""The kernels' numerical constants, named once.

A module-level Python float used in a ``@ti.func`` compiles to the same constant as the
literal it replaces, so naming them changes no result bit (the regression hashes pin it).
"""

FAR = 1e30
"""Beyond any gap, coordinate or projection of a scene, in widths: the start of a running
minimum (``-FAR`` of a running maximum)."""

TINY = 1e-12
"""A length in widths, or a fraction of the size it is compared with, that counts as zero:
far above the rounding of O(1) values in f64 (1e-16) and far below any length of a scene."""

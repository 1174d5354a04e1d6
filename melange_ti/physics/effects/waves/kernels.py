"""The waves' Taichi side, as the step takes it: its terms (:mod:`.coupling`), its stages
(:mod:`.grid`) and the kernel that refreshes the grid after the host set it."""

import taichi as ti

from ...data.schema import Arrays
from ...step.parts import Part, Stage
from . import grid
from .coupling import deposit as post_drift
from .coupling import force

# phi's kick with the icebergs' (after their forces); after the correction, the grid's step
# (what they displaced, eta += dt G phi, the absorbing layer: every part parallel)
STAGES = (
    ("forces", Stage("wave_kick", grid.kick_grid, (Part(grid.kick_grid),))),
    ("correction", Stage("waves", grid.waves_serial, (Part(grid.update), Part(grid.sponge), Part(grid.pressure_surface)))),
)

arr = ti.types.ndarray()


@ti.kernel
def refresh(cfg: arr, own: arr):
    """``GPHI = G PHI`` and ``ETA_P = A ETA`` after the host set the wave grid (the step
    keeps them current); every loop parallel, as the step's (on a device a loop over the
    grid on one thread would stop at the driver's cap)."""
    a = ti.static(Arrays(cfg=cfg, own=own))
    grid.refresh(a)


__all__ = ["force", "post_drift", "STAGES", "refresh"]

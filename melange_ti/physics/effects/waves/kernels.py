"""The waves' Taichi side, as the step takes it: its terms (:mod:`.coupling`), its stages
(:mod:`.grid`) and the kernel that refreshes the grid after the host set it."""

import taichi as ti

from ...data.schema import Arrays
from ...step.parts import Part, Stage
from . import grid
from .coupling import close_all, force, offset_kick


@ti.func
def waves_serial(fx: ti.template(), a: ti.template()):
    """The grid's stage in one serial function (the serial form)."""
    close_all(fx, a)
    grid._update(a, False)
    grid._sponge_serial(a)
    grid._pressure_surface(a, False)


# phi's kick with the icebergs' (after their forces) when a wave step opens; after the
# correction, the grid's step when one closes (what they displaced, eta += Dt G phi, the
# absorbing layer, the phase: every part parallel, its loops empty on the other steps)
STAGES = (
    ("forces", Stage("wave_kick", grid.kick_grid, (Part(grid.kick_grid),))),
    (
        "correction",
        Stage(
            "waves",
            waves_serial,
            (Part(close_all), Part(grid.update), Part(grid.sponge), Part(grid.pressure_surface)),
        ),
    ),
)

arr = ti.types.ndarray()


@ti.kernel
def refresh(cfg: arr, own: arr):
    """``GPHI = G PHI`` and ``ETA_P = A ETA`` after the host set the wave grid (the step
    keeps them current); every loop parallel, as the step's (on a device a loop over the
    grid on one thread would stop at the driver's cap)."""
    a = ti.static(Arrays(cfg=cfg, own=own))
    grid.refresh(a)


__all__ = ["force", "offset_kick", "STAGES", "refresh"]

"""Broad phase: how far each body may move this step, and a counting sort of body centres
into hashed cells along x, so that the narrow phase meets only bodies in adjacent cells.

A body's reach is how far any of its points may move this step, including what one impulse
from the fastest body could add (``(1 + e) * SPEED_MAX``); bodies closer than the sum of
their bounding radii and reaches are candidate pairs. A chain of impulses can exceed even
that; the step then detects again (:func:`outran`, the ``check`` stage).
"""

import taichi as ti

from .schema import Body, BodyInt, Cell, Config, Param, Scratch


@ti.func
def speed(a: ti.template(), i):
    """Fastest speed of any point of body i."""
    b = ti.static(a.b)
    return ti.sqrt(b[i, Body.VX] ** 2 + b[i, Body.VZ] ** 2) + ti.abs(b[i, Body.OM]) * b[i, Body.BOUND]


@ti.func
def reach(a: ti.template(), i):
    """How far body i may move this step (stored in ``Body.REACH``; ``Body.MOTION`` at its
    current velocities)."""
    dt = a.par[Param.DT]
    motion = dt * speed(a, i)
    a.b[i, Body.MOTION] = motion
    r = motion + dt * (1.0 + a.par[Param.RESTITUTION]) * a.scr[Scratch.SPEED_MAX]
    a.b[i, Body.REACH] = r
    return r


@ti.func
def outran(a: ti.template(), i):
    """1 if body i now moves farther this step than the reach it was searched with."""
    return ti.cast(a.par[Param.DT] * speed(a, i) > a.b[i, Body.REACH] * (1.0 + 1e-9) + 1e-12, ti.i32)


@ti.func
def cell_size(a: ti.template()):
    # Bodies closer than the sum of their inflated bounding radii lie in adjacent cells.
    return 2.0 * (a.par[Param.BOUND_MAX] + a.scr[Scratch.REACH_MAX]) + 1e-9


@ti.func
def cell_of(x, size, ncells):
    return ti.cast(ti.cast(ti.floor(x / size), ti.i64) & (ncells - 1), ti.i32)


@ti.func
def scan_cells(a: ti.template()):
    cells = ti.static(a.cells)
    ncells = a.cfg[Config.NCELLS]
    total = 0
    for c in range(ti.cast(ncells, ti.i32)):
        cells[c, Cell.START] = total
        cells[c, Cell.FILL] = total
        total += cells[c, Cell.COUNT]
        cells[c, Cell.COUNT] = 0
    cells[ncells, Cell.START] = total


# ---------------------------------------------------------------- the stage, serial form
@ti.func
def broad_serial(fx: ti.template(), a: ti.template()):
    n = a.b.shape[0]
    vmax = 0.0
    for i in range(n):
        vmax = ti.max(vmax, speed(a, i))
    a.scr[Scratch.SPEED_MAX] = vmax
    rmax = 0.0
    for i in range(n):
        rmax = ti.max(rmax, reach(a, i))
    a.scr[Scratch.REACH_MAX] = rmax
    if ti.static(fx.collisions):
        size = cell_size(a)
        ncells = a.cfg[Config.NCELLS]
        for i in range(n):
            c = cell_of(a.b[i, Body.X], size, ncells)
            a.bi[i, BodyInt.CELL] = c
            a.cells[c, Cell.COUNT] += 1
        scan_cells(a)
        for i in range(n):
            c = a.bi[i, BodyInt.CELL]
            a.bi[a.cells[c, Cell.FILL], BodyInt.SORTED] = i
            a.cells[c, Cell.FILL] += 1


# ---------------------------------------------------------------- the stage, parallel form
@ti.func
def speed_all(fx: ti.template(), a: ti.template()):
    a.scr[Scratch.SPEED_MAX] = 0.0
    for i in range(a.b.shape[0]):
        ti.atomic_max(a.scr[Scratch.SPEED_MAX], speed(a, i))


@ti.func
def reach_all(fx: ti.template(), a: ti.template()):
    a.scr[Scratch.REACH_MAX] = 0.0
    for i in range(a.b.shape[0]):
        ti.atomic_max(a.scr[Scratch.REACH_MAX], reach(a, i))


@ti.func
def bin_count(fx: ti.template(), a: ti.template()):
    size = cell_size(a)
    ncells = a.cfg[Config.NCELLS]
    for i in range(a.b.shape[0]):
        c = cell_of(a.b[i, Body.X], size, ncells)
        a.bi[i, BodyInt.CELL] = c
        ti.atomic_add(a.cells[c, Cell.COUNT], 1)


@ti.func
def bin_scan(fx: ti.template(), a: ti.template()):
    scan_cells(a)


@ti.func
def bin_fill(fx: ti.template(), a: ti.template()):
    for i in range(a.bi.shape[0]):
        c = a.bi[i, BodyInt.CELL]
        slot = ti.atomic_add(a.cells[c, Cell.FILL], 1)
        a.bi[slot, BodyInt.SORTED] = i

"""Broad phase: how far each body may move this step, and a counting sort of body centres
into hashed cells along x, so that the narrow phase meets only bodies in adjacent cells.

A body's reach is how far any of its points may move this step, including what one impulse
from the fastest body could add (``(1 + e) * SPEED_MAX``); bodies closer than the sum of
their bounding radii and reaches are candidate pairs. A chain of impulses can exceed even
that; the step then detects again (:func:`outran`, the ``check`` stage).
"""

import taichi as ti

from ..data.schema import Body, BodyInt, Cell, Config, Param, Scratch

# The parallel form's maximum speed: each chunk of bodies takes its own, then one atomic per
# chunk (a maximum is exact in any order: the same bits as one atomic per body, which made
# two threads take turns at one cache line 100,000 times a step; docs/performance.md)
CHUNK_BITS = 8
CHUNK = 1 << CHUNK_BITS


@ti.func
def speed(a: ti.template(), i):
    """Fastest speed of any point of body i."""
    b = ti.static(a.b)
    return ti.sqrt(b[i, Body.VX] ** 2 + b[i, Body.VZ] ** 2) + ti.abs(b[i, Body.OM]) * b[i, Body.BOUND]


@ti.func
def motion(a: ti.template(), i):
    """How far body i moves this step at its current velocities (stored in
    ``Body.MOTION``); returns its :func:`speed`."""
    v = speed(a, i)
    a.b[i, Body.MOTION] = a.par[Param.DT] * v
    return v


@ti.func
def margin(a: ti.template()):
    """What one impulse from the fastest body may add to any body's motion this step."""
    return a.par[Param.DT] * (1.0 + a.par[Param.RESTITUTION]) * a.scr[Scratch.SPEED_MAX]


@ti.func
def reach(a: ti.template(), i, mg):
    """How far body i may move this step: its motion plus the margin ``mg`` (:func:`margin`).
    Computed where it is needed rather than stored, so that the broad phase needs one pass
    over the bodies, not two."""
    return a.b[i, Body.MOTION] + mg


@ti.func
def set_reach_max(a: ti.template()):
    """``Scratch.REACH_MAX``, the largest :func:`reach`, from the fastest speed alone: adding
    the same margin and scaling by dt are monotone in floating point, so the largest reach
    is the fastest body's, bit for bit."""
    a.scr[Scratch.REACH_MAX] = a.par[Param.DT] * a.scr[Scratch.SPEED_MAX] + margin(a)


@ti.func
def outran(a: ti.template(), i):
    """1 if body i now moves farther this step than the reach it was searched with."""
    return ti.cast(a.par[Param.DT] * speed(a, i) > reach(a, i, margin(a)) * (1.0 + 1e-9) + 1e-12, ti.i32)


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
        vmax = ti.max(vmax, motion(a, i))
    a.scr[Scratch.SPEED_MAX] = vmax
    set_reach_max(a)
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
def motion_all(fx: ti.template(), a: ti.template()):
    """Every body's motion, the fastest speed and the largest reach."""
    a.scr[Scratch.SPEED_MAX] = 0.0
    n = a.b.shape[0]
    for c in range((n + CHUNK - 1) >> CHUNK_BITS):  # a shift: SPIR-V has no // of a shape
        vmax = 0.0
        for i in range(c * CHUNK, ti.min(n, (c + 1) * CHUNK)):
            vmax = ti.max(vmax, motion(a, i))
        ti.atomic_max(a.scr[Scratch.SPEED_MAX], vmax)
    set_reach_max(a)


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

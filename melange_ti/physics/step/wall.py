"""The wall's contact (effect declared in :mod:`..effects.wall`): found here (:func:`detect`), one per
iceberg, from the discs within reach; the impulse pass and the correction visit it before the
body's partners (the contact law of :mod:`.impulses` with infinite mass; normal +x)."""

import taichi as ti

from ..data.schema import Body, BodyInt, Config, Param
from ..numerics import FAR
from ..shape.discs import disc, to_world
from ..shape.hydrostatics import halves
from .broad import margin, reach


@ti.func
def gap(a: ti.template(), i):
    """Smallest gap between body i's discs and the wall at the current position."""
    b = ti.static(a.b)
    k = ti.cast(a.cfg[Config.K], ti.i32)
    c, s = b[i, Body.COS], b[i, Body.SIN]
    hw, hh = halves(a, i)
    r = b[i, Body.RADIUS]
    g = FAR
    for d in range(ti.cast(a.cfg[Config.DISCS], ti.i32)):
        local, has = disc(a, i, d, k, hw, hh, r)
        if has:
            pa = to_world(local, b[i, Body.X], b[i, Body.Z], c, s)
            g = ti.min(g, pa[0] - r - a.par[Param.WALL_X])
    return g


@ti.func
def detect(a: ti.template(), i):
    """Body i's wall contact, if a disc is within its reach: the contact height is the
    mean of the discs' heights weighted by ``motion - gap`` (or ``reach - gap`` for a
    standby contact), as for a pair (:func:`.narrow.narrow`)."""
    b = ti.static(a.b)
    c, s = b[i, Body.COS], b[i, Body.SIN]
    hw, hh = halves(a, i)
    r = b[i, Body.RADIUS]
    rch = reach(a, i, margin(a))
    motion = b[i, Body.MOTION]
    wall_x = a.par[Param.WALL_X]
    a.bi[i, BodyInt.WALL_ON] = 0
    if b[i, Body.X] - b[i, Body.BOUND] - rch < wall_x:
        k = ti.cast(a.cfg[Config.K], ti.i32)
        wsum = 0.0
        pz = 0.0
        wsum2 = 0.0
        pz2 = 0.0
        g_min = FAR
        for d in range(ti.cast(a.cfg[Config.DISCS], ti.i32)):
            local, has = disc(a, i, d, k, hw, hh, r)
            pa = to_world(local, b[i, Body.X], b[i, Body.Z], c, s)
            g = pa[0] - r - wall_x
            if has and g < rch:
                if g < motion:
                    wsum += motion - g
                    pz += (motion - g) * pa[1]
                wsum2 += rch - g
                pz2 += (rch - g) * pa[1]
                g_min = ti.min(g_min, g)
        if g_min < rch:
            a.bi[i, BodyInt.WALL_ON] = 1
            b[i, Body.WALL_PZ] = pz / wsum if wsum > 0 else pz2 / wsum2
            b[i, Body.WALL_GAP] = g_min

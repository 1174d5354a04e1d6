"""Disc geometry and the normal impulse law (Taichi functions; docs/model.md).

Each rectangle carries ``discs`` equal discs, ``k = discs/4`` per face, their centres spread
evenly around the rectangle inset by the radius (face ``f`` starts at an inset corner and
takes ``k`` equal steps towards the next), so the union is tangent to the true faces and the
spacing on the longest face is exactly ``2 radius`` (see :func:`melange_ti.geometry.disc_radius`).
A polygon's discs (a scene with one: ``Effects.vertices``) lie edge by edge from the corners
of its outline moved inwards by the radius (:func:`polygon_disc`; the layout of
:func:`melange_ti.geometry.polygon_discs`).
"""

import taichi as ti

from ..data.schema import Body
from ..numerics import TINY
from .hydrostatics import polygons


@ti.func
def disc_local(a, k, hw, hh, r):
    """Centre of disc ``a`` in the body frame (u along the width, v along the thickness)."""
    f = a // k
    t = (a % k) / k
    iu = hw - r
    iv = hh - r
    u = 0.0
    v = 0.0
    if f == 0:
        u = iu
        v = -iv + 2.0 * iv * t
    elif f == 1:
        u = iu - 2.0 * iu * t
        v = iv
    elif f == 2:
        u = -iu
        v = iv - 2.0 * iv * t
    else:
        u = -iu + 2.0 * iu * t
        v = -iv
    return ti.Vector([u, v])


@ti.func
def to_world(local, x, z, c, s):
    """Body-frame point -> world point for a body at (x, z) with cos/sin of its tilt."""
    return ti.Vector([x + local[0] * c - local[1] * s, z + local[0] * s + local[1] * c])


@ti.func
def cross2(u, w):
    """z-component of the 2-D cross product ``u x w``."""
    return u[0] * w[1] - u[1] * w[0]


@ti.func
def face_line(f, hw, hh, r):
    """Face ``f``'s disc line in the body frame: its first disc centre (u0, v0), the unit
    direction (du, dv) towards the next corner and its length (matches :func:`disc_local`:
    disc ``ia`` of the face sits at ``(u0, v0) + ia * length / k * (du, dv)``)."""
    iu = hw - r
    iv = hh - r
    su, sv, du, dv, length = 1.0, -1.0, 0.0, 1.0, 2.0 * iv
    if f == 1:
        su, sv, du, dv, length = 1.0, 1.0, -1.0, 0.0, 2.0 * iu
    elif f == 2:
        su, sv, du, dv, length = -1.0, 1.0, 0.0, -1.0, 2.0 * iv
    elif f == 3:
        su, sv, du, dv, length = -1.0, -1.0, 1.0, 0.0, 2.0 * iu
    return su * iu, sv * iv, du, dv, length


@ti.func
def line_window(a0, d, limit, lo, hi):
    """Narrow [lo, hi] to the integers ``t`` with ``|a0 + t d| <= limit`` (with a little
    slack: callers still test each point exactly)."""
    lo_out = lo
    hi_out = hi
    slack = 1e-9 * (limit + ti.abs(a0)) + TINY
    if ti.abs(d) > 1e-300:
        inv = 1.0 / d
        t1 = (-limit - slack - a0) * inv
        t2 = (limit + slack - a0) * inv
        if d < 0:
            t1, t2 = t2, t1
        lo_out = ti.max(lo, ti.cast(ti.min(ti.max(ti.ceil(t1), -1.0), 1e9), ti.i32))
        hi_out = ti.min(hi, ti.cast(ti.max(ti.min(ti.floor(t2), 1e9), -1.0), ti.i32))
    elif ti.abs(a0) > limit + slack:
        lo_out = 1
        hi_out = 0
    return lo_out, hi_out


@ti.func
def polygon_disc(a: ti.template(), i, e, j):
    """Disc ``j`` of edge ``e`` of body ``i``'s polygon, in its body frame: from the edge's
    inset corner towards the next in ``NDISC{e}`` equal steps (:func:`melange_ti.geometry.polygon_discs`)."""
    b = ti.static(a.b)
    count = ti.cast(b[i, Body.CORNERS], ti.i32)
    e1 = e + 1
    if e1 >= count:
        e1 = 0
    pu, pv = b[i, Body.IU0 + 2 * e], b[i, Body.IU0 + 2 * e + 1]
    qu, qv = b[i, Body.IU0 + 2 * e1], b[i, Body.IU0 + 2 * e1 + 1]
    t = j / b[i, Body.NDISC0 + e]
    return ti.Vector([pu + t * (qu - pu), pv + t * (qv - pv)])


@ti.func
def disc(a: ti.template(), i, d, k, hw, hh, r):
    """Body i's disc ``d`` in its body frame, and whether it has one: the rectangle's layout
    (from its half width and thickness ``hw``, ``hh``, :func:`..hydrostatics.halves`), or a
    polygon's (edge by edge; disc d beyond its own count: none)."""
    local = ti.Vector([0.0, 0.0])
    has = 1
    if ti.static(polygons(a)):
        has = 0
        first = 0
        for e in range(ti.cast(a.b[i, Body.CORNERS], ti.i32)):
            n = ti.cast(a.b[i, Body.NDISC0 + e], ti.i32)
            if has == 0 and d < first + n:
                local = polygon_disc(a, i, e, d - first)
                has = 1
            first += n
    else:
        local = disc_local(d, k, hw, hh, r)
    return local, has


@ti.func
def offset_term(du_, dv_, d2, au, av, ri, rj):
    """Gap and weighted-sum term of a disc pair whose offset from j's disc to i's disc (at
    (au, av)) is (du_, dv_) in j's frame, ``d2 = du_^2 + dv_^2 > 0``."""
    dist = ti.sqrt(d2)
    g = dist - ri - rj
    inv = 1.0 / dist
    t = (rj + 0.5 * g) * inv
    return g, ti.Vector([1.0, au - du_ + du_ * t, av - dv_ + dv_ * t, du_ * inv, dv_ * inv])

"""An outline's edges as the narrow phase sees them (Taichi functions): its edges in a fixed
order, each from the inset corner its discs start at (a rectangle's four faces, 0: +u, 1: +v,
2: -u, 3: -v, :func:`.discs.face_line`; a polygon's edges from its inset corners,
:func:`.discs.polygon_disc`), one body's edges seen from another's frame, the discs' spacing
along them, and the separating-axis test of two boxes that hold the outlines. The one narrow
phase (:func:`melange_ti.physics.step.narrow.narrow`) asks these for every outline; on an
axis-aligned edge a polygon's edge and a rectangle's face give the same numbers to the bit."""

import taichi as ti

from ...geometry import MAX_VERTICES
from ..data.schema import Body
from ..numerics import TINY
from .discs import face_line, offset_term
from .hydrostatics import polygons

FACE_BITS = max(1, (MAX_VERTICES - 1).bit_length())  # an edge's index in a candidate list's code


@ti.func
def grown(hw, hh, r, grow):
    """A rectangle's half sizes grown by a disc radius ``r`` and by ``grow``: the box a disc's
    centre must be inside to touch one of its discs with room ``grow``."""
    return hw + r + grow, hh + r + grow


@ti.func
def boxes_apart(cu, cv, c, s, hwi, hhi, hwj, hhj, gap):
    """Separating-axis test of two rectangles, in i's frame: j's centre (cu, cv), j's tilt
    relative to i (cos c, sin s). True when they are more than ``gap`` apart on some axis."""
    ac = ti.abs(c)
    as_ = ti.abs(s)
    # i's axes
    far = ti.abs(cu) > hwi + hwj * ac + hhj * as_ + gap or ti.abs(cv) > hhi + hwj * as_ + hhj * ac + gap
    # j's axes: u_j = (c, s), v_j = (-s, c)
    pu = cu * c + cv * s
    pv = -cu * s + cv * c
    far = far or ti.abs(pu) > hwj + hwi * ac + hhi * as_ + gap or ti.abs(pv) > hhj + hwi * as_ + hhi * ac + gap
    return far


@ti.func
def edges(a: ti.template(), i):
    """How many edges body ``i``'s outline has: 4 for a rectangle, a polygon's corners."""
    count = 4
    if ti.static(polygons(a)):
        count = ti.cast(a.b[i, Body.CORNERS], ti.i32)
    return count


@ti.func
def edge_discs(a: ti.template(), i, k):
    """How many discs each of body ``i``'s edges holds: ``k`` on a rectangle's faces, a
    polygon's ``NDISC0`` (the one disc rule gives every edge of an outline the same count,
    :func:`melange_ti.geometry.polygon_discs`)."""
    n = k
    if ti.static(polygons(a)):
        n = ti.cast(a.b[i, Body.NDISC0], ti.i32)
    return n


@ti.func
def box(a: ti.template(), i, hw, hh):
    """Half sizes of a box about body ``i``'s centre, in its frame, that holds its outline:
    a rectangle's own (``hw``, ``hh``: :func:`..hydrostatics.halves`), a polygon's bounding
    circle's square."""
    bu, bv = hw, hh
    if ti.static(polygons(a)):
        bu = a.b[i, Body.BOUND]
        bv = bu
    return bu, bv


@ti.func
def edge_line(a: ti.template(), i, e, k, hw, hh, r):
    """Edge ``e``'s disc line in body ``i``'s frame: its first disc centre (u0, v0), the unit
    direction (du, dv) towards the next, its length and how many discs it holds (disc ``ia``
    at ``(u0, v0) + ia * length / n * (du, dv)``). A rectangle's face from its half sizes
    (:func:`.discs.face_line`, ``k`` discs), a polygon's edge from its inset corners and
    ``NDISC{e}`` (:func:`.discs.polygon_disc`'s layout). The two agree on an axis-aligned
    edge to the last bit (a unit direction of exact zeros and ones)."""
    u0, v0, du, dv, length, n = 0.0, 0.0, 0.0, 0.0, 0.0, k
    if ti.static(polygons(a)):
        b = ti.static(a.b)
        e1 = e + 1
        if e1 >= ti.cast(b[i, Body.CORNERS], ti.i32):
            e1 = 0
        u0, v0 = b[i, Body.IU0 + 2 * e], b[i, Body.IU0 + 2 * e + 1]
        eu = b[i, Body.IU0 + 2 * e1] - u0
        ev = b[i, Body.IU0 + 2 * e1 + 1] - v0
        length = ti.sqrt(eu * eu + ev * ev)
        if length > 0:
            du, dv = eu / length, ev / length
        n = ti.cast(b[i, Body.NDISC0 + e], ti.i32)
    else:
        u0, v0, du, dv, length = face_line(e, hw, hh, r)
    return u0, v0, du, dv, length, n


@ti.func
def edge_spacing(length, n, size):
    """An edge's disc spacing and its inverse (0 for an edge of zero length, which holds n
    coincident discs: every index is then in range; ``size`` the body's scale)."""
    st = length / n
    inv_st = 0.0
    if st > TINY * size:
        inv_st = 1.0 / st
    return st, inv_st


@ti.func
def face_in_j(u0, v0, du, dv, length, n, cu, cv, c, s):
    """i's edge (:func:`edge_line`) in j's frame: its discs are at ``(au0, av0) + ia (dau, dav)``.
    j's centre is at (cu, cv) in i's frame, and (c, s) is j's tilt relative to i."""
    step = length / n
    eu = u0 - cu
    ev = v0 - cv
    return eu * c + ev * s, -eu * s + ev * c, step * (du * c + dv * s), step * (-du * s + dv * c)


@ti.func
def j_face(au, av, pu, pv, du, dv):
    """For a disc of i at (au, av) in j's frame and j's edge from (pu, pv) along the unit
    (du, dv): its offset across the edge (``perp``, outwards) and along it from the edge's
    first disc (``along``). Disc ``ib`` of the edge is ``off = along - ib * st`` away along it."""
    eu = au - pu
    ev = av - pv
    return eu * dv - ev * du, eu * du + ev * dv


@ti.func
def pair_term(perp, off, du, dv, d2, au, av, ri, rj):
    """Gap and weighted-sum term (1, contact point u, v, normal u, v; j's frame) of the disc
    pair at offset (perp, off) from j's disc on the edge along (du, dv), ``d2 = perp^2 + off^2 > 0``."""
    # offset from j's disc to i's disc, in j's frame (the outward normal is (dv, -du))
    return offset_term(perp * dv + off * du, off * dv - perp * du, d2, au, av, ri, rj)

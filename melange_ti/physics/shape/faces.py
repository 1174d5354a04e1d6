"""A rectangle's faces as the narrow phase sees them (Taichi functions): its four faces in a
fixed order (0: +u, 1: +v, 2: -u, 3: -v, each from the inset corner its discs start at;
:func:`.discs.face_line`), one rectangle's faces seen from another's frame, the discs'
spacing along them, and the separating-axis test of two rectangles. The rectangles' narrow
phase (:func:`melange_ti.physics.step.narrow.narrow`) asks these; a polygon's discs are
searched edge by edge instead (:func:`.discs.polygon_disc`)."""

import taichi as ti

from ..numerics import TINY
from .discs import face_line, offset_term

FACES = 4  # a rectangle's faces, in the order above
FACE_BITS = 2  # a face's index in a candidate list's code (FACES <= 1 << FACE_BITS)


@ti.func
def grown(hw, hh, r, grow):
    """A rectangle's half sizes grown by a disc radius ``r`` and by ``grow``: the box a disc's
    centre must be inside to touch one of its discs with room ``grow``."""
    return hw + r + grow, hh + r + grow


@ti.func
def face_spacing(hw, hh, r, k):
    """A rectangle's disc-centre rectangle (half sizes ``iu``, ``iv``) and its disc spacing
    along the u- and v-faces for ``k`` discs per face, with their inverses (0 for a face of
    zero length, which holds k coincident discs: every index is then in range)."""
    iu = hw - r
    iv = hh - r
    stu = 2.0 * iu / k
    stv = 2.0 * iv / k
    inv_stu = 0.0
    inv_stv = 0.0
    if stu > TINY * (hw + hh):
        inv_stu = 1.0 / stu
    if stv > TINY * (hw + hh):
        inv_stv = 1.0 / stv
    return iu, iv, stu, stv, inv_stu, inv_stv


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
def face_in_j(fa, k, hwi, hhi, ri, cu, cv, c, s):
    """i's face ``fa`` in j's frame: its discs are at ``(au0, av0) + ia (dau, dav)``. j's
    centre is at (cu, cv) in i's frame, and (c, s) is j's tilt relative to i."""
    u0, v0, du, dv, length = face_line(fa, hwi, hhi, ri)
    step = length / k
    eu = u0 - cu
    ev = v0 - cv
    return eu * c + ev * s, -eu * s + ev * c, step * (du * c + dv * s), step * (-du * s + dv * c)


@ti.func
def j_face(fb, au, av, iuj, ivj, stu, stv, inv_stu, inv_stv):
    """For a disc of i at (au, av) in j's frame and j's face ``fb``: its offset across the
    face (``perp``) and along it from the face's first disc (``along``), and the face's disc
    spacing and its inverse. Face fb's disc ``ib`` is ``along - ib * st`` away along it."""
    perp = au - iuj
    along = av + ivj
    st = stv
    inv_st = inv_stv
    if fb == 1:
        perp, along, st, inv_st = av - ivj, iuj - au, stu, inv_stu
    elif fb == 2:
        perp, along = au + iuj, ivj - av
    elif fb == 3:
        perp, along, st, inv_st = av + ivj, au + iuj, stu, inv_stu
    return perp, along, st, inv_st


@ti.func
def pair_term(fb, perp, off, d2, au, av, ri, rj):
    """Gap and weighted-sum term (1, contact point u, v, normal u, v; j's frame) of the disc
    pair at offset (perp, off) from j's disc on face fb, ``d2 = perp^2 + off^2 > 0``."""
    # offset from j's disc to i's disc, in j's frame
    du_, dv_ = perp, off
    if fb == 1:
        du_, dv_ = -off, perp
    elif fb == 2:
        du_, dv_ = perp, -off
    elif fb == 3:
        du_, dv_ = off, perp
    return offset_term(du_, dv_, d2, au, av, ri, rj)

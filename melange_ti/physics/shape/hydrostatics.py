"""Exact hydrostatics of a rotated rectangle under a flat sea surface (Taichi functions).

The submerged part is the rectangle clipped at the water line. Its area ``A`` and first
moments ``Sx = int (x - x_G) dA``, ``Sz = int (z - z_G) dA`` (about the centre of mass) follow
from Green's theorem summed edge by edge over the clipped boundary: each edge below the water
contributes fully, an edge that crosses contributes its submerged piece, and the water-line
segment from the exit to the entry crossing closes the polygon. Units: widths, g = rho_w = 1.

The divisors 6 and 12 come in as arguments (:func:`divisors`): on a SPIR-V device they are
read at run time (``Param.SIX``, ``Param.TWELVE``), because its compiler turns a division by a
constant into a multiplication by the reciprocal, which is not correctly rounded (on lavapipe
a third of f32 quotients differ by an ulp), while a division by a run-time value rounds as on
the CPU. On the CPU they are the literals, and the code is what it was.
"""

import taichi as ti

from ..data.schema import Param
from ..forms.fmath import on_spirv
from ..numerics import FAR


@ti.func
def divisors(par: ti.template()):
    """``(6, 12)``, the moments' divisors: literals on the CPU, read from ``par`` on a SPIR-V
    device (above)."""
    six, twelve = 6.0, 12.0
    if ti.static(on_spirv()):
        six, twelve = par[Param.SIX], par[Param.TWELVE]
    return six, twelve


@ti.func
def _segment(px, pz, qx, qz, six):
    """Contribution of the directed segment p->q to (A, Sx, Sz) of a CCW polygon (``six`` = 6)."""
    cross = px * qz - qx * pz
    return ti.Vector([0.5 * cross, cross * (px + qx) / six, cross * (pz + qz) / six])


@ti.func
def corner(k: ti.template(), hw, hh, c, s):
    """Corner ``k`` (CCW from the lower right in the body frame) relative to the centre."""
    su = ti.static((1.0, 1.0, -1.0, -1.0)[k])
    sv = ti.static((-1.0, 1.0, 1.0, -1.0)[k])
    return ti.Vector([su * hw * c - sv * hh * s, su * hw * s + sv * hh * c])


@ti.func
def _wet_edge(k: ti.template(), hw, hh, c, s, level):
    """Edge ``k`` (corner k to k + 1, CCW) clipped at the water line ``level`` (relative to
    the centre): its submerged piece ``a -> b``, whether any of it is submerged, whether it
    leaves the water at ``b`` and whether it enters it at ``a``."""
    p = corner(k, hw, hh, c, s)
    q = corner((k + 1) % 4, hw, hh, c, s)
    p_wet = p[1] < level
    q_wet = q[1] < level
    a = p
    b = q
    leaves = 0
    enters = 0
    if p_wet != q_wet:
        t = (level - p[1]) / (q[1] - p[1])
        cut = ti.Vector([p[0] + t * (q[0] - p[0]), level])
        if p_wet:
            b = cut
            leaves = 1
        else:
            a = cut
            enters = 1
    return a, b, ti.cast(p_wet or q_wet, ti.i32), leaves, enters


@ti.func
def submerged_moments(z, c, s, hw, hh, water_level, six):
    """(A, Sx, Sz) of the part of the rectangle below ``water_level``.

    ``z``: centre height; ``c``, ``s``: cosine and sine of the tilt (CCW); ``hw``, ``hh``:
    half width and half thickness; ``six``: 6, read at run time (above). Moments are about
    the centre of mass, so the buoyancy torque is ``rho g Sx``.
    """
    level = water_level - z
    m = ti.Vector([0.0, 0.0, 0.0])
    exit_pt = ti.Vector([0.0, 0.0])
    entry_pt = ti.Vector([0.0, 0.0])
    crossed = 0
    for k in ti.static(range(4)):
        a, b, wet, leaves, enters = _wet_edge(k, hw, hh, c, s, level)
        if wet:
            m += _segment(a[0], a[1], b[0], b[1], six)
        if leaves:
            exit_pt = b
            crossed = 1
        if enters:
            entry_pt = a
            crossed = 1
    if crossed:
        m += _segment(exit_pt[0], exit_pt[1], entry_pt[0], entry_pt[1], six)
    return m


@ti.func
def _second(px, pz, qx, qz, twelve):
    """Contribution of the directed segment p->q to (int x^2 dA, int z^2 dA) of a CCW polygon
    (``twelve`` = 12)."""
    cross = px * qz - qx * pz
    return ti.Vector([cross * (px * px + px * qx + qx * qx) / twelve, cross * (pz * pz + pz * qz + qz * qz) / twelve])


@ti.func
def _cube_integral(a, b, length):
    """``int_0^length |a + b s|^3 ds`` for ``b = +-1``."""
    e = a + b * length
    return (e * ti.abs(e) ** 3 - a * ti.abs(a) ** 3) / (4.0 * b)


@ti.func
def wetted(z, c, s, hw, hh, water_level, ux, uz, six, twelve):
    """The submerged part of the rectangle, for the water's dynamic loads (form drag, added
    mass): its area ``A``, polar second moment ``J = int |r|^2 dA`` about the centre of mass,
    its width projected on the unit direction (ux, uz), ``P = max r.u - min r.u``, and
    ``R3 = int over the wetted faces of |r x n|^3 ds`` (n the face's normal), the lever-arm
    integral of a quadratic pressure drag on rotation. Relative to the centre of mass.
    ``six``, ``twelve``: 6 and 12, read at run time (above)."""
    level = water_level - z
    area = 0.0
    second = ti.Vector([0.0, 0.0])
    lo = FAR
    hi = -FAR
    r3 = 0.0
    exit_pt = ti.Vector([0.0, 0.0])
    entry_pt = ti.Vector([0.0, 0.0])
    crossed = 0
    for k in ti.static(range(4)):
        a, b, wet, leaves, enters = _wet_edge(k, hw, hh, c, s, level)
        if leaves:
            exit_pt = b
            crossed = 1
        if enters:
            entry_pt = a
            crossed = 1
        if wet:
            m = _segment(a[0], a[1], b[0], b[1], six)
            area += m[0]
            second += _second(a[0], a[1], b[0], b[1], twelve)
            for end in ti.static(range(2)):
                pt = a if end == 0 else b
                proj = pt[0] * ux + pt[1] * uz
                lo = ti.min(lo, proj)
                hi = ti.max(hi, proj)
            # the face's unit tangent t and outward normal n = (t_z, -t_x) of a CCW polygon:
            # r x n = r_x n_z - r_z n_x = -(r . t), linear along the face with slope -1
            length = ti.sqrt((b[0] - a[0]) ** 2 + (b[1] - a[1]) ** 2)
            if length > 0:
                tx = (b[0] - a[0]) / length
                tz = (b[1] - a[1]) / length
                r3 += _cube_integral(-(a[0] * tx + a[1] * tz), -1.0, length)
    if crossed:
        m = _segment(exit_pt[0], exit_pt[1], entry_pt[0], entry_pt[1], six)
        area += m[0]
        second += _second(exit_pt[0], exit_pt[1], entry_pt[0], entry_pt[1], twelve)
    width = 0.0
    if hi >= lo:
        width = hi - lo
    return ti.Vector([area, second[0] + second[1], width, r3])

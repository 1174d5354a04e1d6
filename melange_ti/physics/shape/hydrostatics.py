"""Exact hydrostatics of an iceberg's outline under a flat sea surface (Taichi functions).

Every outline is a convex polygon; a scene of rectangles alone stores each as its width and
thickness (two numbers), any other scene every outline's corners (``Effects.vertices``), and
:func:`corner_uv` alone tells the two stores apart: one clipper serves every outline, and a
rectangle gives the same bits from either store. The submerged part is the outline clipped at
the water line. Its area ``A`` and first moments ``Sx = int (x - x_G) dA``, ``Sz = int (z - z_G)
dA`` (about the centre of mass) follow from Green's theorem summed edge by edge over the clipped
boundary: each edge below the water contributes fully, an edge that crosses contributes its
submerged piece, and the water-line
segment from the exit to the entry crossing closes the polygon. Units: widths, g = rho_w = 1.

The divisors 6 and 12 come in as arguments (:func:`divisors`): on a SPIR-V device they are
read at run time (``Param.SIX``, ``Param.TWELVE``), because its compiler turns a division by a
constant into a multiplication by the reciprocal, which is not correctly rounded (on lavapipe
a third of f32 quotients differ by an ulp), while a division by a run-time value rounds as on
the CPU. On the CPU they are the literals, and the code is what it was.
"""

import taichi as ti

from ..data.schema import Body, Param
from ..fmath import on_spirv
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


def polygons(a) -> bool:
    """Whether the outlines are read from their corners (static: a scene with a polygon)."""
    return a.fx is not None and a.fx.vertices > 0


def corners(a) -> int:
    """How many corners the kernels visit per outline (static): 4 for rectangles, else the
    most corners of any polygon in the scene (``Effects.vertices``)."""
    return a.fx.vertices if polygons(a) else 4


@ti.func
def halves(a: ti.template(), i):
    """A rectangle's half width and half thickness (read once per clipping; 0 for polygons)."""
    hw, hh = 0.0, 0.0
    if ti.static(not polygons(a)):
        hw, hh = 0.5 * a.b[i, Body.WIDTH], 0.5 * a.b[i, Body.THICK]
    return hw, hh


@ti.func
def _wet_edge(a: ti.template(), i, k: ti.template(), c, s, hw, hh, level):
    """Edge ``k`` (corner k to the next, counter-clockwise) clipped at the water line ``level``
    (relative to the centre): its submerged piece ``a -> b``, whether any of it is submerged,
    whether it leaves the water at ``b`` and whether it enters it at ``a``. A polygon's edges
    past its own corners are dry (the kernels visit the scene's most corners)."""
    pu, pv, qu, qv, has = _edge_uv(a, i, k, hw, hh)
    p = ti.Vector([pu * c - pv * s, pu * s + pv * c])
    q = ti.Vector([qu * c - qv * s, qu * s + qv * c])
    p_wet = has and p[1] < level
    q_wet = has and q[1] < level
    pa = p
    pb = q
    leaves = 0
    enters = 0
    if p_wet != q_wet:
        t = (level - p[1]) / (q[1] - p[1])
        cut = ti.Vector([p[0] + t * (q[0] - p[0]), level])
        if p_wet:
            pb = cut
            leaves = 1
        else:
            pa = cut
            enters = 1
    return pa, pb, ti.cast(p_wet or q_wet, ti.i32), leaves, enters


@ti.func
def submerged_moments(a: ti.template(), i, water_level, six):
    """(A, Sx, Sz) of the part of body ``i``'s outline below ``water_level``, at its pose
    (centre height, cached cos and sin of the tilt); ``six``: 6, read at run time (above).
    Moments are about the centre of mass, so the buoyancy torque is ``rho g Sx``.
    """
    hw, hh = halves(a, i)
    level = water_level - a.b[i, Body.Z]
    c, s = a.b[i, Body.COS], a.b[i, Body.SIN]
    m = ti.Vector([0.0, 0.0, 0.0])
    exit_pt = ti.Vector([0.0, 0.0])
    entry_pt = ti.Vector([0.0, 0.0])
    crossed = 0
    for k in ti.static(range(corners(a))):
        pa, pb, wet, leaves, enters = _wet_edge(a, i, k, c, s, hw, hh, level)
        if wet:
            m += _segment(pa[0], pa[1], pb[0], pb[1], six)
        if leaves:
            exit_pt = pb
            crossed = 1
        if enters:
            entry_pt = pa
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
def wetted(a: ti.template(), i, water_level, ux, uz, six, twelve):
    """The submerged part of body ``i``'s outline, for the water's dynamic loads (form drag, added
    mass): its area ``A``, polar second moment ``J = int |r|^2 dA`` about the centre of mass,
    its width projected on the unit direction (ux, uz), ``P = max r.u - min r.u``, and
    ``R3 = int over the wetted faces of |r x n|^3 ds`` (n the face's normal), the lever-arm
    integral of a quadratic pressure drag on rotation. Relative to the centre of mass.
    ``six``, ``twelve``: 6 and 12, read at run time (above)."""
    hw, hh = halves(a, i)
    level = water_level - a.b[i, Body.Z]
    c, s = a.b[i, Body.COS], a.b[i, Body.SIN]
    area = 0.0
    second = ti.Vector([0.0, 0.0])
    lo = FAR
    hi = -FAR
    r3 = 0.0
    exit_pt = ti.Vector([0.0, 0.0])
    entry_pt = ti.Vector([0.0, 0.0])
    crossed = 0
    for k in ti.static(range(corners(a))):
        pa, pb, wet, leaves, enters = _wet_edge(a, i, k, c, s, hw, hh, level)
        if leaves:
            exit_pt = pb
            crossed = 1
        if enters:
            entry_pt = pa
            crossed = 1
        if wet:
            m = _segment(pa[0], pa[1], pb[0], pb[1], six)
            area += m[0]
            second += _second(pa[0], pa[1], pb[0], pb[1], twelve)
            for end in ti.static(range(2)):
                pt = pa if end == 0 else pb
                proj = pt[0] * ux + pt[1] * uz
                lo = ti.min(lo, proj)
                hi = ti.max(hi, proj)
            # the face's unit tangent t and outward normal n = (t_z, -t_x) of a CCW polygon:
            # r x n = r_x n_z - r_z n_x = -(r . t), linear along the face with slope -1
            length = ti.sqrt((pb[0] - pa[0]) ** 2 + (pb[1] - pa[1]) ** 2)
            if length > 0:
                tx = (pb[0] - pa[0]) / length
                tz = (pb[1] - pa[1]) / length
                r3 += _cube_integral(-(pa[0] * tx + pa[1] * tz), -1.0, length)
    if crossed:
        m = _segment(exit_pt[0], exit_pt[1], entry_pt[0], entry_pt[1], six)
        area += m[0]
        second += _second(exit_pt[0], exit_pt[1], entry_pt[0], entry_pt[1], twelve)
    width = 0.0
    if hi >= lo:
        width = hi - lo
    return ti.Vector([area, second[0] + second[1], width, r3])


# ------------------------------------------------------------------ the waves' strips
# The waves take an iceberg's submerged part strip by strip (physics/effects/waves/coupling.py):
# its horizontal reach, the thickness of its part below the water line along a vertical line,
# where it crosses the water line, and that part as a polygon. One clipper for every outline:
# a line is cut by each edge's half-plane in the body frame (:func:`_plane`), and the corners
# are turned into the world one way (:func:`corner_uv`). A rectangle's edges have normals of
# exact zeros and ones, so it gets the arithmetic the wave runs were recorded with (its two
# pairs of faces), whether given by width and thickness or by its four corners.


@ti.func
def corner_uv(a: ti.template(), i, k: ti.template(), hw, hh):
    """Corner ``k`` of body ``i``'s outline in its body frame (counter-clockwise; a rectangle's
    from its half sizes ``hw``, ``hh`` from the lower right, a polygon's as stored)."""
    u, v = 0.0, 0.0
    if ti.static(not polygons(a)):
        u = ti.static((1.0, 1.0, -1.0, -1.0)[k]) * hw
        v = ti.static((-1.0, 1.0, 1.0, -1.0)[k]) * hh
    else:
        u, v = a.b[i, Body.U0 + 2 * k], a.b[i, Body.U0 + 2 * k + 1]
    return u, v


@ti.func
def _edge_uv(a: ti.template(), i, k: ti.template(), hw, hh):
    """Edge ``k`` of the outline in the body frame, corner k to the next, and whether the
    outline has it (the kernels visit the scene's most corners)."""
    pu, pv = corner_uv(a, i, k, hw, hh)
    qu, qv = corner_uv(a, i, ti.static((k + 1) % corners(a)), hw, hh)
    real = True
    if ti.static(polygons(a)):
        count = ti.cast(a.b[i, Body.CORNERS], ti.i32)
        if k + 1 == count:
            qu, qv = corner_uv(a, i, 0, hw, hh)  # the closing edge
        real = k < count
    return pu, pv, qu, qv, real


_RECT_NU = (1.0, 0.0, -1.0, 0.0)  # a rectangle's outward normals, edge by edge
_RECT_NV = (0.0, 1.0, 0.0, -1.0)


@ti.func
def _plane(a: ti.template(), i, k: ti.template(), hw, hh):
    """Edge ``k``'s half-plane in the body frame, ``n . (u, v) <= h``: its outward unit normal
    ``n`` and ``h``, and whether the outline has the edge. A rectangle's are (1, 0), (0, 1),
    (-1, 0), (0, -1) and its half sizes, exactly; a polygon's from its corners, normalised: a
    rectangle written out then has the same exact normals, so the same bits (an unnormalised
    normal saves a square root but rounds :func:`_clip`'s ratios otherwise: tested,
    ``tests/physics/test_one_shape.py``)."""
    nu, nv, h, real = 0.0, 0.0, 0.0, 1
    if ti.static(not polygons(a)):
        nu = _RECT_NU[k]  # (a ti.static(...) on the right would bind a new name in this branch)
        nv = _RECT_NV[k]
        h = hw if ti.static(k % 2 == 0) else hh
    else:
        pu, pv, qu, qv, has = _edge_uv(a, i, k, hw, hh)
        eu, ev = qu - pu, qv - pv
        length = ti.sqrt(eu * eu + ev * ev)
        real = has and length > 0
        if real:
            nu, nv = ev / length, -eu / length
            h = nu * pu + nv * pv
    return nu, nv, h, real


@ti.func
def _clip(a: ti.template(), i, hw, hh, lo, hi, base, ou, ov, su, sv):
    """Narrow [lo, hi] to the t where the line ``(u, v) = (ou, ov) + (t - base) (su, sv)`` (in
    body ``i``'s frame) is inside its outline, edge by edge; empty: hi <= lo."""
    for k in ti.static(range(corners(a))):
        nu, nv, h, real = _plane(a, i, k, hw, hh)
        if real:
            off = nu * ou + nv * ov
            rate = nu * su + nv * sv
            if rate != 0:
                t = base + (h - off) / rate
                if rate > 0:
                    hi = ti.min(hi, t)
                else:
                    lo = ti.max(lo, t)
            elif off > h:
                hi = lo
    return lo, hi


@ti.func
def reach(a: ti.template(), i, c, s, hw, hh):
    """The outline's horizontal extent about its centre, [lo, hi] (its corners' least and
    greatest x; a rectangle's half sizes ``hw``, ``hh``, :func:`halves`)."""
    lo, hi = FAR, -FAR
    for k in ti.static(range(corners(a))):
        u, v = corner_uv(a, i, k, hw, hh)
        x = u * c - v * s
        real = True
        if ti.static(polygons(a)):
            real = k < ti.cast(a.b[i, Body.CORNERS], ti.i32)
        if real:
            lo = ti.min(lo, x)
            hi = ti.max(hi, x)
    return lo, hi


@ti.func
def column(a: ti.template(), i, x, xc, zc, c, s, hw, hh, wl):
    """The vertical line at ``x`` through the outline at centre (xc, zc), tilt (c, s): the
    thickness ``h`` of its part below the still water line ``wl``, and that part's first
    moment about the centre's height, ``M1 = int (z - zc) dz``."""
    h = 0.0
    m1 = 0.0
    d = x - xc
    # u = d c + (z - zc) s, v = -d s + (z - zc) c
    lo, hi = _clip(a, i, hw, hh, -FAR, FAR, zc, d * c, -d * s, s, c)
    if lo < hi and lo < wl:
        top = ti.min(hi, wl)
        h = top - lo
        m1 = h * (0.5 * (lo + top) - zc)
    return h, m1


@ti.func
def waterline(a: ti.template(), i, xc, zc, c, s, hw, hh, wl):
    """Where the outline crosses the still water line: the interval [p, q] of x (q <= p: it
    does not)."""
    e = wl - zc
    # u = (x - xc) c + e s, v = -(x - xc) s + e c
    return _clip(a, i, hw, hh, -FAR, FAR, xc, e * s, e * c, c, -s)


@ti.func
def _keep(px, pz, m, ax, az, bx, bz, wl):
    """One edge a -> b of a clipping at the water line ``wl``: corner a kept when below it, and
    the edge's crossing of it when it crosses."""
    if az < wl:
        px[m] = ax
        pz[m] = az
        m += 1
    if (az < wl) != (bz < wl):
        f = (wl - az) / (bz - az)
        px[m] = ax + f * (bx - ax)
        pz[m] = wl
        m += 1
    return px, pz, m


@ti.func
def below(a: ti.template(), i, xc, zc, c, s, hw, hh, wl):
    """The outline's part below the still water line, a convex polygon of at most one corner
    more than the outline's (counter-clockwise; vectors of the scene's most corners plus two):
    x, z and the count."""
    n = ti.static(corners(a))
    px = ti.Vector([0.0 for _ in ti.static(range(n + 2))])
    pz = ti.Vector([0.0 for _ in ti.static(range(n + 2))])
    m = 0
    for k in ti.static(range(n)):
        pu, pv, qu, qv, real = _edge_uv(a, i, k, hw, hh)
        if real:
            ax = xc + pu * c - pv * s
            az = zc + pu * s + pv * c
            bx = xc + qu * c - qv * s
            bz = zc + qu * s + qv * c
            px, pz, m = _keep(px, pz, m, ax, az, bx, bz, wl)
    return px, pz, m

"""Exact hydrostatics of an iceberg's outline under a flat sea surface (Taichi functions).

The outline is a rectangle (from its width and thickness) or a convex polygon (from its
corners, when the scene has one: ``Effects.vertices``); :func:`corner` alone tells them apart,
and one clipper serves both. The submerged part is the outline clipped at the water line. Its area ``A`` and first
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
def corner(a: ti.template(), i, k: ti.template(), c, s, hw, hh):
    """Corner ``k`` of body ``i``'s outline, counter-clockwise, relative to its centre of mass
    (world orientation, cos and sin of the tilt ``c``, ``s``): a rectangle's from its half
    width and thickness ``hw``, ``hh`` (:func:`halves`; from the lower right), a polygon's from
    its body-frame corners."""
    r = ti.Vector([0.0, 0.0])
    if ti.static(not polygons(a)):
        su = ti.static((1.0, 1.0, -1.0, -1.0)[k])
        sv = ti.static((-1.0, 1.0, 1.0, -1.0)[k])
        r = ti.Vector([su * hw * c - sv * hh * s, su * hw * s + sv * hh * c])
    else:
        u, v = a.b[i, Body.U0 + 2 * k], a.b[i, Body.U0 + 2 * k + 1]
        r = ti.Vector([u * c - v * s, u * s + v * c])
    return r


@ti.func
def _wet_edge(a: ti.template(), i, k: ti.template(), c, s, hw, hh, level):
    """Edge ``k`` (corner k to the next, counter-clockwise) clipped at the water line ``level``
    (relative to the centre): its submerged piece ``a -> b``, whether any of it is submerged,
    whether it leaves the water at ``b`` and whether it enters it at ``a``. A polygon's edges
    past its own corners are dry (the kernels visit the scene's most corners)."""
    n = ti.static(corners(a))
    p = ti.Vector([0.0, 0.0])
    q = ti.Vector([0.0, 0.0])
    has = 1
    if ti.static(polygons(a)):
        p, q, has = _edge(a, i, k, c, s)
    else:
        p = corner(a, i, k, c, s, hw, hh)
        q = corner(a, i, ti.static((k + 1) % n), c, s, hw, hh)
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
# where it crosses the water line, and that part as a polygon. A rectangle's come from its
# two pairs of faces (the arithmetic the wave runs were recorded with), a polygon's from its
# corners (each edge a half-plane of the convex outline).


@ti.func
def _slab(lo, hi, base, offset, half, slope):
    """Narrow [lo, hi] to where ``|offset + (t - base) slope| <= half`` (one pair of the
    rectangle's faces, along a line with free coordinate t); empty: hi <= lo."""
    if slope != 0:
        t1 = base + (-half - offset) / slope
        t2 = base + (half - offset) / slope
        lo = ti.max(lo, ti.min(t1, t2))
        hi = ti.min(hi, ti.max(t1, t2))
    elif ti.abs(offset) > half:
        hi = lo
    return lo, hi


@ti.func
def _edge(a: ti.template(), i, k: ti.template(), c, s):
    """A polygon's edge ``k``, corner k to the next counter-clockwise (relative to the centre),
    and whether the polygon has it (the kernels visit the scene's most corners)."""
    count = ti.cast(a.b[i, Body.CORNERS], ti.i32)
    p = corner(a, i, k, c, s, 0.0, 0.0)
    q = corner(a, i, ti.static((k + 1) % corners(a)), c, s, 0.0, 0.0)
    if k + 1 == count:
        q = corner(a, i, 0, c, s, 0.0, 0.0)  # the closing edge
    return p, q, k < count


@ti.func
def _line(a: ti.template(), i, c, s, ox, oz, dx, dz):
    """The range [lo, hi] of t where the line ``(ox, oz) + t (dx, dz)`` (relative to the
    centre) is inside a polygon's outline: the interior is left of every counter-clockwise
    edge, one linear condition on t per edge; hi <= lo: it misses."""
    lo = -FAR
    hi = FAR
    for k in ti.static(range(corners(a))):
        p, q, real = _edge(a, i, k, c, s)
        if real:
            ex, ez = q[0] - p[0], q[1] - p[1]
            rate = ex * dz - ez * dx  # d/dt of the cross product (q - p) x (X(t) - p)
            at0 = ex * (oz - p[1]) - ez * (ox - p[0])
            if rate > 0:
                lo = ti.max(lo, -at0 / rate)
            elif rate < 0:
                hi = ti.min(hi, -at0 / rate)
            elif at0 < 0:
                hi = lo
    return lo, hi


@ti.func
def reach(a: ti.template(), i, c, s, hw, hh):
    """The outline's horizontal extent about its centre, [lo, hi] (a rectangle's from its half
    width and thickness ``hw``, ``hh``, :func:`halves`)."""
    lo, hi = 0.0, 0.0
    if ti.static(not polygons(a)):
        hi = hw * ti.abs(c) + hh * ti.abs(s)
        lo = -hi
    else:
        lo, hi = FAR, -FAR
        count = ti.cast(a.b[i, Body.CORNERS], ti.i32)
        for k in ti.static(range(corners(a))):
            if k < count:
                x = corner(a, i, k, c, s, 0.0, 0.0)[0]
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
    if ti.static(not polygons(a)):
        d = x - xc
        # u = d c + (z - zc) s, v = -d s + (z - zc) c
        lo, hi = _slab(-FAR, FAR, zc, d * c, hw, s)
        lo, hi = _slab(lo, hi, zc, -d * s, hh, c)
        if lo < hi and lo < wl:
            top = ti.min(hi, wl)
            h = top - lo
            m1 = h * (0.5 * (lo + top) - zc)
    else:
        lo, hi = _line(a, i, c, s, x - xc, 0.0, 0.0, 1.0)  # t = z - zc
        level = wl - zc
        if lo < hi and lo < level:
            top = ti.min(hi, level)
            h = top - lo
            m1 = h * 0.5 * (lo + top)
    return h, m1


@ti.func
def waterline(a: ti.template(), i, xc, zc, c, s, hw, hh, wl):
    """Where the outline crosses the still water line: the interval [p, q] of x (q <= p: it
    does not)."""
    p, q = 0.0, 0.0
    if ti.static(not polygons(a)):
        e = wl - zc
        # u = (x - xc) c + e s, v = -(x - xc) s + e c
        lo, hi = _slab(-FAR, FAR, xc, e * s, hw, c)
        p, q = _slab(lo, hi, xc, e * c, hh, -s)
    else:
        lo, hi = _line(a, i, c, s, 0.0, wl - zc, 1.0, 0.0)  # t = x - xc
        p, q = xc + lo, xc + hi
    return p, q


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
    if ti.static(not polygons(a)):
        for k in ti.static(range(4)):
            su = ti.static((1.0, 1.0, -1.0, -1.0)[k])
            sv = ti.static((-1.0, 1.0, 1.0, -1.0)[k])
            su2 = ti.static((1.0, 1.0, -1.0, -1.0)[(k + 1) % 4])
            sv2 = ti.static((-1.0, 1.0, 1.0, -1.0)[(k + 1) % 4])
            ax = xc + su * hw * c - sv * hh * s
            az = zc + su * hw * s + sv * hh * c
            bx = xc + su2 * hw * c - sv2 * hh * s
            bz = zc + su2 * hw * s + sv2 * hh * c
            px, pz, m = _keep(px, pz, m, ax, az, bx, bz, wl)
    else:
        for k in ti.static(range(n)):
            p, q, real = _edge(a, i, k, c, s)
            if real:
                ax, az = xc + p[0], zc + p[1]
                bx, bz = xc + q[0], zc + q[1]
                px, pz, m = _keep(px, pz, m, ax, az, bx, bz, wl)
    return px, pz, m

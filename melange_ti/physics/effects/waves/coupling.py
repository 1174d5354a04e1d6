"""The waves' coupling to the icebergs, once per wave step: when it opens, the wave's pressure
on each (the ``force`` term, as a kick of the wave step) and its submerged area taken out of
the source column; when it closes, its submerged area put back (:func:`close_all`), so the
water gets what each displaced over the wave step. Both from the iceberg's submerged part
strip by strip (:mod:`melange_ti.physics.effects.waves` has the physics)."""

import taichi as ti

from ...data.schema import Body, Param
from ...numerics import FAR
from . import SUB, Wave
from .grid import cells, closes, every, opens


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
def column(x, xc, zc, c, s, hw, hh, wl):
    """The vertical line at ``x`` through the rectangle of centre (xc, zc), axes
    ``u = (c, s)``, ``v = (-s, c)`` and half sizes hw, hh: the thickness ``h`` of its part
    below the still water line ``wl``, and that part's first moment about the centre's
    height, ``M1 = int (z - zc) dz``."""
    d = x - xc
    # u = d c + (z - zc) s, v = -d s + (z - zc) c
    lo, hi = _slab(-FAR, FAR, zc, d * c, hw, s)
    lo, hi = _slab(lo, hi, zc, -d * s, hh, c)
    h = 0.0
    m1 = 0.0
    if lo < hi and lo < wl:
        top = ti.min(hi, wl)
        h = top - lo
        m1 = h * (0.5 * (lo + top) - zc)
    return h, m1


@ti.func
def waterline(xc, zc, c, s, hw, hh, wl):
    """Where the rectangle crosses the still water line: the interval [p, q] of x (q <= p:
    it does not)."""
    e = wl - zc
    # u = (x - xc) c + e s, v = -(x - xc) s + e c
    lo, hi = _slab(-FAR, FAR, xc, e * s, hw, c)
    return _slab(lo, hi, xc, e * c, hh, -s)


@ti.func
def submerged(xc, zc, c, s, hw, hh, wl):
    """The rectangle's part below the still water line, a convex polygon of at most five
    corners (counter-clockwise): x, z and the count."""
    px = ti.Vector([0.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    pz = ti.Vector([0.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    n = 0
    for k in ti.static(range(4)):
        su = ti.static((1.0, 1.0, -1.0, -1.0)[k])
        sv = ti.static((-1.0, 1.0, 1.0, -1.0)[k])
        su2 = ti.static((1.0, 1.0, -1.0, -1.0)[(k + 1) % 4])
        sv2 = ti.static((-1.0, 1.0, 1.0, -1.0)[(k + 1) % 4])
        ax = xc + su * hw * c - sv * hh * s
        az = zc + su * hw * s + sv * hh * c
        bx = xc + su2 * hw * c - sv2 * hh * s
        bz = zc + su2 * hw * s + sv2 * hh * c
        if az < wl:
            px[n] = ax
            pz[n] = az
            n += 1
        if (az < wl) != (bz < wl):
            f = (wl - az) / (bz - az)
            px[n] = ax + f * (bx - ax)
            pz[n] = wl
            n += 1
    return px, pz, n


@ti.func
def edges(px, pz, n, wl):
    """The edges of the convex polygon (px, pz, n corners, counter-clockwise) as
    :func:`area_left_of` takes them: each edge k's x range [lo, hi], its height above the
    still water line ``wl`` at lo, its slope dz/dx and its sign in the area (-1 running to
    +x, +1 back); a vertical edge, or a slot past the n-th, has an empty range."""
    lo = ti.Vector([0.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    hi = ti.Vector([0.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    z0 = ti.Vector([0.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    slope = ti.Vector([0.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    sign = ti.Vector([0.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    if n >= 3:
        for k in ti.static(range(px.n)):
            if k < n:
                ax, az = px[k], pz[k]
                bx, bz = px[0], pz[0]  # the next corner, the first after the last
                if ti.static(k + 1 < px.n):
                    if k + 1 < n:
                        bx, bz = px[k + 1], pz[k + 1]
                if ax != bx:
                    slope[k] = (bz - az) / (bx - ax)
                    if ax < bx:
                        lo[k], hi[k], z0[k], sign[k] = ax, bx, az - wl, -1.0
                    else:
                        lo[k], hi[k], z0[k], sign[k] = bx, ax, bz - wl, 1.0
    return lo, hi, z0, slope, sign


@ti.func
def area_left_of(lo, hi, z0, slope, sign, xe):
    """Area of the polygon whose :func:`edges` these are left of the line x = xe: ``-int z
    dx`` around its part left of xe, the edges clipped to x <= xe (the piece of the line x =
    xe has no dx), each a linear z over its clipped range; heights from the water line, so
    the terms stay the size of the iceberg, not of its distance from the origin. No branch
    and no division per call: an iceberg's strips take it at every strip edge, twice."""
    area = 0.0
    for k in ti.static(range(lo.n)):
        t = ti.min(ti.max(xe, lo[k]), hi[k]) - lo[k]
        area += sign[k] * t * (z0[k] + 0.5 * slope[k] * t)
    return area


@ti.func
def extent(c, s, hw, hh):
    """Half the horizontal extent of a rectangle."""
    return hw * ti.abs(c) + hh * ti.abs(s)


@ti.func
def strips(a: ti.template(), xa, xb):
    """The strips of the grid (index range, inclusive) that meet [xa, xb]; strip q runs
    from ``x0 + q ds`` to ``x0 + (q + 1) ds``, ``ds = dx / SUB``."""
    m = cells(a)
    ds = a.par[Param.WAVE_DX] / SUB
    x0 = a.par[Param.WAVE_START]
    lo = ti.max(0, ti.cast(ti.floor((xa - x0) / ds), ti.i32))
    hi = ti.min(m * SUB - 1, ti.cast(ti.floor((xb - x0) / ds), ti.i32))
    return lo, hi


@ti.func
def edge_x(a: ti.template(), q):
    """x of the left edge of strip q."""
    return a.par[Param.WAVE_START] + q * (a.par[Param.WAVE_DX] / SUB)


@ti.func
def weights(a: ti.template(), q):
    """Strip q's centre lies between cell centres j0 and j1 = j0 + 1, at fraction f from j0;
    at the grid's ends (before the first centre, after the last) j1 = j0 and f = 0."""
    m = cells(a)
    u = (q + 0.5) / SUB - 0.5  # in cell-centre units
    j0 = ti.cast(ti.floor(u), ti.i32)
    f = u - j0
    if j0 < 0:
        j0, f = 0, 0.0
    if j0 >= m - 1:
        j0, f = m - 1, 0.0
    return j0, ti.min(j0 + 1, m - 1), f


@ti.func
def eta_at(a: ti.template(), q):
    """The surface the icebergs' pressure is taken from (``ETA_P``), at strip q's centre."""
    j0, j1, f = weights(a, q)
    return (1.0 - f) * a.own[j0, Wave.ETA_P] + f * a.own[j1, Wave.ETA_P]


@ti.func
def force(a: ti.template(), i):
    """The wave's pressure on iceberg i beyond its still-water buoyancy, ``(f_x, f_z, tau)``,
    times K when a wave step opens (the kick of the wave step, ``Dt = K dt``), else 0; at the
    opening its submerged area also leaves the source column (:func:`displace`)."""
    f = ti.Vector([0.0, 0.0, 0.0])
    if opens(a):
        f = pressure(a, i) * (every(a) * 1.0)
        b = ti.static(a.b)
        displace(a, i, b[i, Body.X], b[i, Body.Z], -1.0)
        b[i, Body.PUSH_X] = 0.0
        b[i, Body.PUSH_Z] = 0.0
    return f


@ti.func
def pressure(a: ti.template(), i):
    """The wave's pressure on iceberg i beyond its still-water buoyancy, ``(f_x, f_z, tau)``:
    minus the gradient over the pose of ``rho g sum_q eta_q A_q``, ``A_q`` the iceberg's
    submerged area in strip q (:mod:`melange_ti.physics.effects.waves`). Per strip from a to b:
    ``dA/dx_G = h(a) - h(b)``, ``dA/dz_G = -L`` (the waterline's length in it),
    ``dA/dtheta = M1(b) - M1(a) - int_L (x - x_G) dx``."""
    b = ti.static(a.b)
    xc, zc, c, s = b[i, Body.X], b[i, Body.Z], b[i, Body.COS], b[i, Body.SIN]
    hw, hh = 0.5 * b[i, Body.WIDTH], 0.5 * b[i, Body.THICK]
    wl = a.par[Param.WATER]
    ext = extent(c, s, hw, hh)
    lo, hi = strips(a, xc - ext, xc + ext)
    p, q = waterline(xc, zc, c, s, hw, hh, wl)
    f = ti.Vector([0.0, 0.0, 0.0])
    h_a, m_a = column(edge_x(a, lo), xc, zc, c, s, hw, hh, wl)
    for k in range(lo, hi + 1):
        xa = edge_x(a, k)
        xb = edge_x(a, k + 1)
        h_b, m_b = column(xb, xc, zc, c, s, hw, hh, wl)
        wa = ti.max(p, xa)
        wb = ti.min(q, xb)
        length = 0.0
        if wb > wa:
            length = wb - wa
        eta = eta_at(a, k)
        f += eta * ti.Vector([h_b - h_a, length, m_a - m_b + length * (0.5 * (wa + wb) - xc)])
        h_a, m_a = h_b, m_b
    return f


@ti.func
def displace(a: ti.template(), i, xc, zc, sign):
    """Iceberg i's submerged area in each strip with its centre at (xc, zc) and its tilt now,
    times ``sign``, added to the source column (``Wave.SRC``) with the interpolation's
    weights: taken out when a wave step opens (``-1``, at its pose), put back when it closes
    (``+1``, at the pose its drifts reached), so the column then holds what the iceberg's
    drifts displaced over the wave step (what the interaction ``rho g sum_q eta_q A_q``,
    whose gradient the kick used, changed by along them). Each share is rounded to a
    multiple of ``Param.WAVE_Q``: such sums are exact, so the cells' totals do not depend on
    the order of the additions."""
    b = ti.static(a.b)
    wv = ti.static(a.own)
    hw, hh = 0.5 * b[i, Body.WIDTH], 0.5 * b[i, Body.THICK]
    wl = a.par[Param.WATER]
    quantum = a.par[Param.WAVE_Q]
    per_quantum = 1.0 / quantum  # exact (a power of 2): v * per_quantum is v / quantum, without a division per strip
    scale = sign / a.par[Param.WAVE_DX]
    c, s = b[i, Body.COS], b[i, Body.SIN]
    ext = extent(c, s, hw, hh)
    lo, hi = strips(a, xc - ext, xc + ext)
    px, pz, n = submerged(xc, zc, c, s, hw, hh, wl)
    e_lo, e_hi, e_h, e_sl, e_sg = edges(px, pz, n, wl)
    left = area_left_of(e_lo, e_hi, e_h, e_sl, e_sg, edge_x(a, lo))
    for k in range(lo, hi + 1):
        right = area_left_of(e_lo, e_hi, e_h, e_sl, e_sg, edge_x(a, k + 1))
        v = (right - left) * scale
        left = right
        if v != 0:
            j0, j1, w1 = weights(a, k)
            share1 = ti.floor(v * w1 * per_quantum + 0.5) * quantum
            share0 = ti.floor(v * (1.0 - w1) * per_quantum + 0.5) * quantum
            if share0 != 0:
                ti.atomic_add(wv[j0, Wave.SRC], share0)
            if share1 != 0:
                ti.atomic_add(wv[j1, Wave.SRC], share1)


@ti.func
def close_all(fx: ti.template(), a: ti.template()):
    """After every step's overlap correction: each iceberg's pushes added to those since the
    wave step opened; when a wave step closes, its submerged area put back in the source
    column at its pose less those pushes (a parallel loop over the icebergs)."""
    b = ti.static(a.b)
    last = closes(a)
    for i in range(a.b.shape[0]):
        if ti.static(fx.collisions or fx.wall):
            b[i, Body.PUSH_X] += b[i, Body.SHIFT_X]  # the correction's pushes this step
            b[i, Body.PUSH_Z] += b[i, Body.SHIFT_Z]
        if last:
            displace(a, i, b[i, Body.X] - b[i, Body.PUSH_X], b[i, Body.Z] - b[i, Body.PUSH_Z], 1.0)

"""The waves' coupling to the icebergs: the wave's pressure on each (the ``force`` term) and the
water each displaces into the grid (the ``post_drift`` term), from its submerged part
strip by strip (:mod:`melange_ti.physics.effects.waves` has the physics)."""

import taichi as ti

from ...data.schema import Body, Param
from ...numerics import FAR
from . import SUB, Wave
from .grid import cells


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
    """The wave's pressure on iceberg i beyond its still-water buoyancy, ``(f_x, f_z, tau)``:
    minus the gradient over the pose of ``rho g sum_q eta_q A_q``, ``A_q`` the iceberg's
    submerged area in strip q (:mod:`melange_ti.physics.effects.waves`). Per strip from a to b:
    ``dA/dx_G = h(a) - h(b)``, ``dA/dz_G = -L`` (the waterline's length in it),
    ``dA/dtheta = M1(b) - M1(a) - int_L (x - x_G) dx``. Also keeps the pose at the step's
    start, for :func:`deposit`."""
    b = ti.static(a.b)
    xc, zc, c, s = b[i, Body.X], b[i, Body.Z], b[i, Body.COS], b[i, Body.SIN]
    b[i, Body.START_X] = xc
    b[i, Body.START_Z] = zc
    b[i, Body.START_C] = c
    b[i, Body.START_S] = s
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
def deposit(a: ti.template(), i):
    """After the drift: the water iceberg i displaced, its submerged area in each strip now
    minus at the step's start (exactly what the interaction ``rho g sum_q eta_q A_q``, whose
    gradient the kick used, changed by), spread to the cells with the interpolation's
    weights. Each share is rounded to a multiple of ``Param.WAVE_Q``: such sums are exact,
    so the cells' totals do not depend on the order of the additions."""
    b = ti.static(a.b)
    wv = ti.static(a.own)
    hw, hh = 0.5 * b[i, Body.WIDTH], 0.5 * b[i, Body.THICK]
    wl = a.par[Param.WATER]
    quantum = a.par[Param.WAVE_Q]
    per_quantum = 1.0 / quantum  # exact (a power of 2): v * per_quantum is v / quantum, without a division per strip
    inv_dx = 1.0 / a.par[Param.WAVE_DX]
    x1, z1, c1, s1 = b[i, Body.X], b[i, Body.Z], b[i, Body.COS], b[i, Body.SIN]
    x0, z0, c0, s0 = b[i, Body.START_X], b[i, Body.START_Z], b[i, Body.START_C], b[i, Body.START_S]
    e1 = extent(c1, s1, hw, hh)
    e0 = extent(c0, s0, hw, hh)
    lo, hi = strips(a, ti.min(x1 - e1, x0 - e0), ti.max(x1 + e1, x0 + e0))
    px1, pz1, n1 = submerged(x1, z1, c1, s1, hw, hh, wl)
    px0, pz0, n0 = submerged(x0, z0, c0, s0, hw, hh, wl)
    lo1, hi1, h1, sl1, sg1 = edges(px1, pz1, n1, wl)
    lo0, hi0, h0, sl0, sg0 = edges(px0, pz0, n0, wl)
    xa = edge_x(a, lo)
    left = area_left_of(lo1, hi1, h1, sl1, sg1, xa) - area_left_of(lo0, hi0, h0, sl0, sg0, xa)
    for k in range(lo, hi + 1):
        xb = edge_x(a, k + 1)
        right = area_left_of(lo1, hi1, h1, sl1, sg1, xb) - area_left_of(lo0, hi0, h0, sl0, sg0, xb)
        v = (right - left) * inv_dx
        left = right
        if v != 0:
            j0, j1, w1 = weights(a, k)
            share1 = ti.floor(v * w1 * per_quantum + 0.5) * quantum
            share0 = ti.floor(v * (1.0 - w1) * per_quantum + 0.5) * quantum
            if share0 != 0:
                ti.atomic_add(wv[j0, Wave.SRC], share0)
            if share1 != 0:
                ti.atomic_add(wv[j1, Wave.SRC], share1)

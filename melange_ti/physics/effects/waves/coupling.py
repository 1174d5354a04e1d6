"""The waves' coupling to the icebergs, once per wave step: when it opens, the wave's pressure
on each (the ``force`` term, as a kick of the wave step) and its submerged area taken out of
the source column; when it closes, its submerged area put back (:func:`close_all`), so the
water gets what each displaced over the wave step. Both from the iceberg's submerged part
strip by strip (:mod:`melange_ti.physics.effects.waves` has the physics), which the shape
module gives for any outline (:mod:`melange_ti.physics.shape.hydrostatics`: ``reach``,
``column``, ``waterline``, ``below``)."""

import taichi as ti

from ...data.schema import Body, Param
from ...shape import hydrostatics as shape
from . import SUB, Wave
from .grid import cells, closes, every, opens, phase


@ti.func
def edges(px, pz, n, wl):
    """The edges of the convex polygon (px, pz, n corners, counter-clockwise) as
    :func:`area_left_of` takes them: each edge k's x range [lo, hi], its height above the
    still water line ``wl`` at lo, its slope dz/dx and its sign in the area (-1 running to
    +x, +1 back); a vertical edge, or a slot past the n-th, has an empty range."""
    lo = ti.Vector([0.0 for _ in ti.static(range(px.n))])
    hi = ti.Vector([0.0 for _ in ti.static(range(px.n))])
    z0 = ti.Vector([0.0 for _ in ti.static(range(px.n))])
    slope = ti.Vector([0.0 for _ in ti.static(range(px.n))])
    sign = ti.Vector([0.0 for _ in ti.static(range(px.n))])
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
        p = pressure(a, i)
        f = p * (every(a) * 1.0)
        b = ti.static(a.b)
        displace(a, i, b[i, Body.X], b[i, Body.Z], -1.0)
        b[i, Body.PUSH_X] = 0.0
        b[i, Body.PUSH_Z] = 0.0
        b[i, Body.WAVE_FX] = p[0]  # kept over the wave step for the impulses' offset (offset_kick)
        b[i, Body.WAVE_FZ] = p[1]
        b[i, Body.WAVE_TAU] = p[2]
    return f


@ti.func
def offset_kick(a: ti.template(), i):
    """The wave's share of the impulses' half-kick offset at this step (docs/model.md, Waves,
    "Energy"): the wave kicks once per wave step of K steps, and an impulse at its i-th step
    changes the energy the wave step keeps by ``dt/2 (K - 2i) F_w . delta`` (``F_w`` the
    pressure force at the opening, ``delta`` the impulse's change of velocity), so the kick
    the offset is taken from gains ``(K - 2i) F_w`` here; at the opening (i = 0) the wave's
    kick itself, ``K F_w``, is already in it."""
    b = ti.static(a.b)
    k = phase(a)
    share = 0.0
    if k > 0:
        share = (every(a) - 2 * k) * 1.0
    return share * ti.Vector([b[i, Body.WAVE_FX], b[i, Body.WAVE_FZ], b[i, Body.WAVE_TAU]])


@ti.func
def pressure(a: ti.template(), i):
    """The wave's pressure on iceberg i beyond its still-water buoyancy, ``(f_x, f_z, tau)``:
    minus the gradient over the pose of ``rho g sum_q eta_q A_q``, ``A_q`` the iceberg's
    submerged area in strip q (:mod:`melange_ti.physics.effects.waves`). Per strip from a to b:
    ``dA/dx_G = h(a) - h(b)``, ``dA/dz_G = -L`` (the waterline's length in it),
    ``dA/dtheta = M1(b) - M1(a) - int_L (x - x_G) dx``."""
    b = ti.static(a.b)
    xc, zc, c, s = b[i, Body.X], b[i, Body.Z], b[i, Body.COS], b[i, Body.SIN]
    hw, hh = shape.halves(a, i)
    wl = a.par[Param.WATER]
    left, right = shape.reach(a, i, c, s, hw, hh)
    lo, hi = strips(a, xc + left, xc + right)
    p, q = shape.waterline(a, i, xc, zc, c, s, hw, hh, wl)
    f = ti.Vector([0.0, 0.0, 0.0])
    h_a, m_a = shape.column(a, i, edge_x(a, lo), xc, zc, c, s, hw, hh, wl)
    for k in range(lo, hi + 1):
        xa = edge_x(a, k)
        xb = edge_x(a, k + 1)
        h_b, m_b = shape.column(a, i, xb, xc, zc, c, s, hw, hh, wl)
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
    hw, hh = shape.halves(a, i)
    wl = a.par[Param.WATER]
    quantum = a.par[Param.WAVE_Q]
    per_quantum = 1.0 / quantum  # exact (a power of 2): v * per_quantum is v / quantum, without a division per strip
    scale = sign / a.par[Param.WAVE_DX]
    c, s = b[i, Body.COS], b[i, Body.SIN]
    left_x, right_x = shape.reach(a, i, c, s, hw, hh)
    lo, hi = strips(a, xc + left_x, xc + right_x)
    px, pz, n = shape.below(a, i, xc, zc, c, s, hw, hh, wl)
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

"""The waves effect's kernels: the icebergs' columns, the coupling and the wave grid's step.

The physics and its discrete form are in :mod:`.effects.waves`; this module is the Taichi
side. The grid's step (:func:`grid_step`) applies ``G`` through a cosine transform done as a
complex FFT of length ``2M`` (the even extension of the ``M`` cells, ``M`` a power of 2):
bit-reversed load, ``log2(2M)`` butterfly stages, each a loop over ``M`` butterflies that
write disjoint elements, so every loop is parallel and its bits do not depend on the thread
count; two real filters share one complex transform (:func:`apply_filters`). Twiddles, the
bit reversal and the operators' symbols are computed once on the host (numpy), so no kernel
evaluates a trigonometric function.
"""

import taichi as ti

from .columns import Acc, Body, Config, Param, Wave
from .effects.waves import MAX_CELLS, SPONGE_Q, SUB
from .numerics import FAR

MAX_LOG = MAX_CELLS.bit_length()  # butterfly stages of the longest transform, 2 * MAX_CELLS


@ti.func
def _cells(a: ti.template()):
    """The grid's cells, M."""
    return ti.cast(a.cfg[Config.WAVE_CELLS], ti.i32)


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
def area_left_of(px, pz, n, xe):
    """Area of the convex polygon (px, pz, n corners) left of the line x = xe. Taken about
    its first corner: the shoelace terms then stay the size of the iceberg, not of its
    distance from the origin (in f32, at x ~ 500, the difference of two areas a step apart
    would be rounding alone)."""
    area = 0.0
    if n >= 3:
        # clip each edge to x <= xe and sum the shoelace terms of the clipped polygon: the
        # clipped boundary is the kept pieces plus pieces of the line x = xe
        ox, oz = px[0], pz[0]
        qx = ti.Vector([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0])
        qz = ti.Vector([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0])
        m = 0
        for k in range(n):
            ax, az = px[k] - ox, pz[k] - oz
            k2 = k + 1
            if k2 == n:
                k2 = 0
            bx, bz = px[k2] - ox, pz[k2] - oz
            cut = xe - ox
            if ax <= cut:
                qx[m] = ax
                qz[m] = az
                m += 1
            if (ax <= cut) != (bx <= cut):
                f = (cut - ax) / (bx - ax)
                qx[m] = cut
                qz[m] = az + f * (bz - az)
                m += 1
        for k in range(m):
            k2 = k + 1
            if k2 == m:
                k2 = 0
            area += qx[k] * qz[k2] - qx[k2] * qz[k]
        area *= 0.5
    return area


@ti.func
def extent(c, s, hw, hh):
    """Half the horizontal extent of a rectangle."""
    return hw * ti.abs(c) + hh * ti.abs(s)


@ti.func
def strips(a: ti.template(), xa, xb):
    """The strips of the grid (index range, inclusive) that meet [xa, xb]; strip q runs
    from ``x0 + q ds`` to ``x0 + (q + 1) ds``, ``ds = dx / SUB``."""
    m = _cells(a)
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
    m = _cells(a)
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
    return (1.0 - f) * a.wv[j0, Wave.ETA_P] + f * a.wv[j1, Wave.ETA_P]


@ti.func
def force(a: ti.template(), i):
    """The wave's pressure on iceberg i beyond its still-water buoyancy, ``(f_x, f_z, tau)``:
    minus the gradient over the pose of ``rho g sum_q eta_q A_q``, ``A_q`` the iceberg's
    submerged area in strip q (:mod:`.effects.waves`). Per strip from a to b:
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
def _quantize(v, quantum):
    return ti.floor(v / quantum + 0.5) * quantum


@ti.func
def deposit(a: ti.template(), i):
    """After the drift: the water iceberg i displaced, its submerged area in each strip now
    minus at the step's start (exactly what the interaction ``rho g sum_q eta_q A_q``, whose
    gradient the kick used, changed by), spread to the cells with the interpolation's
    weights. Each share is rounded to a multiple of ``Param.WAVE_Q``: such sums are exact,
    so the cells' totals do not depend on the order of the additions."""
    b = ti.static(a.b)
    wv = ti.static(a.wv)
    hw, hh = 0.5 * b[i, Body.WIDTH], 0.5 * b[i, Body.THICK]
    wl = a.par[Param.WATER]
    quantum = a.par[Param.WAVE_Q]
    inv_dx = 1.0 / a.par[Param.WAVE_DX]
    x1, z1, c1, s1 = b[i, Body.X], b[i, Body.Z], b[i, Body.COS], b[i, Body.SIN]
    x0, z0, c0, s0 = b[i, Body.START_X], b[i, Body.START_Z], b[i, Body.START_C], b[i, Body.START_S]
    e1 = extent(c1, s1, hw, hh)
    e0 = extent(c0, s0, hw, hh)
    lo, hi = strips(a, ti.min(x1 - e1, x0 - e0), ti.max(x1 + e1, x0 + e0))
    px1, pz1, n1 = submerged(x1, z1, c1, s1, hw, hh, wl)
    px0, pz0, n0 = submerged(x0, z0, c0, s0, hw, hh, wl)
    left = area_left_of(px1, pz1, n1, edge_x(a, lo)) - area_left_of(px0, pz0, n0, edge_x(a, lo))
    for k in range(lo, hi + 1):
        xb = edge_x(a, k + 1)
        right = area_left_of(px1, pz1, n1, xb) - area_left_of(px0, pz0, n0, xb)
        v = (right - left) * inv_dx
        left = right
        if v != 0:
            j0, j1, w1 = weights(a, k)
            share1 = _quantize(v * w1, quantum)
            share0 = _quantize(v * (1.0 - w1), quantum)
            if share0 != 0:
                ti.atomic_add(wv[j0, Wave.SRC], share0)
            if share1 != 0:
                ti.atomic_add(wv[j1, Wave.SRC], share1)


# ---------------------------------------------------------------- the grid's step
@ti.func
def _fft(a: ti.template(), re: ti.template(), im: ti.template(), sign, parallel: ti.template()):
    """The radix-2 FFT's butterfly passes on columns re, im (bit-reversed input)."""
    if ti.static(parallel):
        for st in ti.static(range(1, MAX_LOG + 1)):
            _butterflies(a, st, re, im, sign)
    else:
        for st in range(1, ti.cast(a.cfg[Config.WAVE_LOG], ti.i32) + 1):
            _butterflies(a, st, re, im, sign)


@ti.func
def _butterflies(a: ti.template(), st, re: ti.template(), im: ti.template(), sign):
    """Pass ``st`` (1-based) of the radix-2 FFT in place on columns re, im (bit-reversed
    input); ``sign`` -1 for the inverse (conjugate twiddles). No loop when ``st`` exceeds
    the transform's passes."""
    wv = ti.static(a.wv)
    m = _cells(a)
    bits = ti.cast(a.cfg[Config.WAVE_LOG], ti.i32)
    count = m if st <= bits else 0
    for t in range(count):
        half = 1 << (st - 1)
        pos = t & (half - 1)
        i0 = ((t >> (st - 1)) << st) + pos
        i1 = i0 + half
        k = pos << (bits - st)
        wr = wv[k, Wave.TWR]
        wi = sign * wv[k, Wave.TWI]
        xr = wv[i1, re] * wr - wv[i1, im] * wi
        xi = wv[i1, re] * wi + wv[i1, im] * wr
        ur = wv[i0, re]
        ui = wv[i0, im]
        wv[i0, re] = ur + xr
        wv[i0, im] = ui + xi
        wv[i1, re] = ur - xr
        wv[i1, im] = ui - xi


@ti.func
def apply_filters(
    a: ti.template(),
    src1: ti.template(),
    sym1: ti.template(),
    dst1: ti.template(),
    src2: ti.template(),
    sym2: ti.template(),
    dst2: ti.template(),
    parallel: ti.template(),
):
    """``dst1 = F1 src1`` and ``dst2 = F2 src2`` for filters diagonal in the grid's cosine
    modes (their values per mode, with the transforms' scale, in columns ``sym1``, ``sym2``),
    in one FFT and one inverse FFT of length 2M: forward of ``ext(src1) + i ext(src2)``
    (``ext`` the even extension, whose transform is the cosine transform), each input's
    spectrum taken apart by conjugate symmetry, filtered, put back as the spectrum of a real
    even output (Hermitian), the two packed as real and imaginary parts, back.
    ``parallel``: every butterfly pass a loop of its own at the kernel's top level (unrolled
    up to the longest transform); else a loop over the passes, for a serial caller (the same
    arithmetic, far less code to compile)."""
    wv = ti.static(a.wv)
    m = _cells(a)
    n = 2 * m
    for q in range(n):
        j = q
        if q >= m:
            j = n - 1 - q
        r = ti.cast(wv[q, Wave.REV], ti.i32)
        wv[r, Wave.RE] = wv[j, src1]
        wv[r, Wave.IM] = wv[j, src2]
    _fft(a, Wave.RE, Wave.IM, 1.0, parallel)
    for k in range(n):
        mode = k
        if k > m:
            mode = n - k
        w_re = 0.0
        w_im = 0.0
        if mode < m:
            other = (n - mode) % n
            zr, zi, yr, yi = wv[mode, Wave.RE], wv[mode, Wave.IM], wv[other, Wave.RE], wv[other, Wave.IM]
            cr, ci = wv[mode, Wave.CR], wv[mode, Wave.CI]
            # the two inputs' transforms at this mode: P = (Z_m + conj Z_-m) / 2, Q = (Z_m - conj Z_-m) / 2i
            amp1 = wv[mode, sym1] * (cr * (0.5 * (zr + yr)) + ci * (0.5 * (zi - yi)))
            amp2 = wv[mode, sym2] * (cr * (0.5 * (zi + yi)) + ci * (-0.5 * (zr - yr)))
            half = 0.5
            if mode == 0:
                half = 1.0
            h1r, h1i = half * amp1 * cr, half * amp1 * ci
            h2r, h2i = half * amp2 * cr, half * amp2 * ci
            if k > m:  # the Hermitian half: conjugates
                h1i, h2i = -h1i, -h2i
            w_re = h1r - h2i
            w_im = h1i + h2r
        r = ti.cast(wv[k, Wave.REV], ti.i32)
        wv[r, Wave.QR] = w_re
        wv[r, Wave.QI] = w_im
    _fft(a, Wave.QR, Wave.QI, -1.0, parallel)
    for j in range(m):
        wv[j, dst1] = wv[j, Wave.QR]
        wv[j, dst2] = wv[j, Wave.QI]


@ti.func
def refresh(a: ti.template()):
    """What the step keeps from the grid's state: ``G PHI`` and the surface at the depth of
    the icebergs' pressure, ``ETA_P = A ETA`` (at a kernel's top level: every loop parallel)."""
    apply_filters(a, Wave.PHI, Wave.KT, Wave.GPHI, Wave.ETA, Wave.AT, Wave.ETA_P, True)


@ti.func
def kick_grid(fx: ti.template(), a: ti.template()):
    """``phi -= dt g eta`` (with the icebergs' kick: both from the step's start)."""
    wv = ti.static(a.wv)
    dt = a.par[Param.DT]
    for j in range(_cells(a)):
        wv[j, Wave.PHI] -= dt * wv[j, Wave.ETA]


@ti.func
def _update(a: ti.template(), parallel: ti.template()):
    """``eta += dt G phi + A q``: the displaced water enters as it was taken, through the
    depth filter ``A``; cleared for the next step."""
    apply_filters(a, Wave.PHI, Wave.KT, Wave.GPHI, Wave.SRC, Wave.AT, Wave.SRC_P, parallel)
    wv = ti.static(a.wv)
    dt = a.par[Param.DT]
    for j in range(_cells(a)):
        wv[j, Wave.ETA] += dt * wv[j, Wave.GPHI] + wv[j, Wave.SRC_P]
        wv[j, Wave.SRC] = 0.0


@ti.func
def _pressure_surface(a: ti.template(), parallel: ti.template()):
    """``ETA_P = A ETA`` for the next step's kick (the transform's second input is the
    cleared ``SRC``, its output unused)."""
    apply_filters(a, Wave.ETA, Wave.AT, Wave.ETA_P, Wave.SRC, Wave.AT, Wave.SRC_P, parallel)


@ti.func
def update(fx: ti.template(), a: ti.template()):
    _update(a, True)


@ti.func
def pressure_surface(fx: ti.template(), a: ti.template()):
    _pressure_surface(a, True)


@ti.func
def sponge(fx: ti.template(), a: ti.template()):
    """The absorbing layer, ``eta <- eta / (1 + dt sigma)``, each cell on its own (parallel:
    no loop over the grid on one thread). The energy it removes, ``rho g / 2 (eta^2 - eta'^2)
    dx`` per cell, is rounded to a multiple of ``SPONGE_Q`` and the cells' shares added with
    atomics into ``red[0, 0]`` (f64 in any form; free after the correction): such sums are
    exact, so the step's total does not depend on the order of the additions (the same bits
    in every form, on any thread count and on a device); then one addition to
    ``wave_absorbed``."""
    wv = ti.static(a.wv)
    dt = a.par[Param.DT]
    dx = a.par[Param.WAVE_DX]
    for _ in range(1):
        a.red[0, 0] = ti.cast(0.0, ti.f64)
    for j in range(_cells(a)):
        sig = wv[j, Wave.SPONGE]
        if sig > 0:
            e = wv[j, Wave.ETA]
            en = e / (1.0 + dt * sig)
            removed = ti.cast(0.5 * (e * e - en * en) * dx, ti.f64)
            share = _quantize(removed, SPONGE_Q)
            if share != 0:
                ti.atomic_add(a.red[0, 0], share)
            wv[j, Wave.ETA] = en
    for _ in range(1):
        a.acc[Acc.WAVE_ABSORBED] += a.red[0, 0]


@ti.func
def waves_serial(fx: ti.template(), a: ti.template()):
    _update(a, False)
    sponge(fx, a)
    _pressure_surface(a, False)

"""The wave grid's kernels: its step (``eta += Dt G phi + q``, the absorbing layer) and ``phi``'s kick,
once per wave step (``Dt = K dt``, ``K`` the time steps per wave step, from ``wave_dt``).

The physics and its discrete form are in :mod:`melange_ti.physics.effects.waves`. The grid's
step applies ``G`` through a cosine transform (DCT-II, and DCT-III back) done as a complex FFT
of ``M`` points (``M`` the cells, a power of 2): the cells reordered, even ones first and odd
ones backwards (Makhoul's order, whose FFT gives the cosine transform after a twist by
``exp(-i pi m / 2M)``), loaded bit-reversed, ``log2(M)`` butterfly stages, two to a loop
over ``M / 4`` groups of four elements that write disjoint elements, so every loop is parallel
and its bits do not depend on the thread count. Two real filters share one complex transform
(:func:`apply_filters`: ``G phi`` and the displaced water); one alone (the pressure surface)
takes transforms of ``M / 2`` points, its cells packed two to a complex number
(:func:`apply_filter`). Twiddles, the bit reversal and the operators' symbols are computed
once on the host (:mod:`.host`), so no kernel evaluates a trigonometric function. The grid is
the effect's table, ``a.own`` (namespace :class:`Wave`), one row per cell.

A wave step opens at the step when ``Wave.PHASE`` (row 0) is 0 (:func:`opens`: ``phi``'s kick
and the icebergs', :mod:`.coupling`) and closes after the step when it is ``K - 1``
(:func:`closes`: the grid's step); the grid's step ends by advancing the phase. Every loop
of a part that a step may skip runs ``0`` times on the other steps (its count times the
gate), never under an ``if`` around it: a loop inside a branch would run on one thread.
"""

import taichi as ti

from ...data.schema import Acc, Config, Param
from . import MAX_CELLS, SPONGE_Q, Wave

MAX_LOG = MAX_CELLS.bit_length() - 1  # butterfly stages of the longest transform, MAX_CELLS points


@ti.func
def cells(a: ti.template()):
    """The grid's cells, M."""
    return ti.cast(a.cfg[Config.WAVE_CELLS], ti.i32)


@ti.func
def every(a: ti.template()):
    """Time steps per wave step, K."""
    return ti.cast(a.cfg[Config.WAVE_EVERY], ti.i32)


@ti.func
def phase(a: ti.template()):
    """Time steps since the last wave step closed."""
    return ti.cast(a.own[0, Wave.PHASE], ti.i32)


@ti.func
def opens(a: ti.template()):
    """1 if this step opens a wave step (the kicks), else 0."""
    return ti.cast(phase(a) == 0, ti.i32)


@ti.func
def closes(a: ti.template()):
    """1 if this step closes a wave step (the grid's step), else 0."""
    return ti.cast(phase(a) == every(a) - 1, ti.i32)


@ti.func
def wave_dt(a: ti.template()):
    """The wave step, ``Dt = K dt``."""
    return a.par[Param.DT] * every(a)


@ti.func
def quantize(v, quantum):
    return ti.floor(v / quantum + 0.5) * quantum


# ---------------------------------------------------------------- the grid's step
@ti.func
def _fft(a: ti.template(), re: ti.template(), im: ti.template(), sign, half: ti.template(), parallel: ti.template(), on):
    """The radix-2 FFT's butterfly passes on columns re, im (bit-reversed input), two at a
    time (:func:`_two_passes`), the last alone when their count is odd: of M points, or of
    M / 2 with ``half`` (the same twiddles, every other one). No loop runs when ``on`` is 0."""
    if ti.static(parallel):
        for q in ti.static(range(MAX_LOG // 2)):
            _two_passes(a, 2 * q + 1, re, im, sign, half, on)
        _last_pass(a, re, im, sign, half, on)
    else:
        for q in range(_passes(a, half) // 2):
            _two_passes(a, 2 * q + 1, re, im, sign, half, on)
        _last_pass(a, re, im, sign, half, on)


@ti.func
def _passes(a: ti.template(), half: ti.template()):
    """The transform's passes: log2 of its points, M or (``half``) M / 2."""
    return ti.cast(a.cfg[Config.WAVE_LOG], ti.i32) - ti.static(1 if half else 0)


@ti.func
def _butterfly(a: ti.template(), k, sign, r0, i0, r1, i1):
    """One radix-2 butterfly of the pair (r0 + i i0, r1 + i i1), twiddle k (of the M-point
    transform's); ``sign`` -1 for the inverse (conjugate twiddles)."""
    wv = ti.static(a.own)
    wr = wv[k, Wave.TWR]
    wi = sign * wv[k, Wave.TWI]
    xr = r1 * wr - i1 * wi
    xi = r1 * wi + i1 * wr
    return r0 + xr, i0 + xi, r0 - xr, i0 - xi


@ti.func
def _two_passes(a: ti.template(), st, re: ti.template(), im: ti.template(), sign, half: ti.template(), on):
    """Passes ``st`` and ``st + 1`` (1-based) of the radix-2 FFT in place on columns re, im,
    fused: each iteration loads four elements, makes the two butterflies of each pass on them
    and stores them (the same arithmetic as pass by pass, half the loads and stores). No loop
    when ``st + 1`` exceeds the transform's passes. Pass st's twiddles are the M-point
    transform's at multiples of ``2^(log2 M - st)``, whatever the transform's length."""
    wv = ti.static(a.own)
    log = ti.cast(a.cfg[Config.WAVE_LOG], ti.i32)
    bits = _passes(a, half)
    count = (1 << bits) // 4 if st + 1 <= bits else 0
    for t in range(count * on):
        h = 1 << (st - 1)
        pos = t & (h - 1)
        j0 = ((t >> (st - 1)) << (st + 1)) + pos
        j1, j2, j3 = j0 + h, j0 + 2 * h, j0 + 3 * h
        k = pos << (log - st)
        r0, i0, r1, i1 = _butterfly(a, k, sign, wv[j0, re], wv[j0, im], wv[j1, re], wv[j1, im])
        r2, i2, r3, i3 = _butterfly(a, k, sign, wv[j2, re], wv[j2, im], wv[j3, re], wv[j3, im])
        r0, i0, r2, i2 = _butterfly(a, pos << (log - st - 1), sign, r0, i0, r2, i2)
        r1, i1, r3, i3 = _butterfly(a, (pos + h) << (log - st - 1), sign, r1, i1, r3, i3)
        wv[j0, re], wv[j0, im], wv[j1, re], wv[j1, im] = r0, i0, r1, i1
        wv[j2, re], wv[j2, im], wv[j3, re], wv[j3, im] = r2, i2, r3, i3


@ti.func
def _last_pass(a: ti.template(), re: ti.template(), im: ti.template(), sign, half: ti.template(), on):
    """The last pass of the radix-2 FFT alone, when the passes are odd in number (no loop
    when they are even)."""
    wv = ti.static(a.own)
    log = ti.cast(a.cfg[Config.WAVE_LOG], ti.i32)
    bits = _passes(a, half)
    count = (1 << bits) // 2 if bits & 1 else 0
    for t in range(count * on):
        j0 = t
        j1 = t + (1 << (bits - 1))
        r0, i0, r1, i1 = _butterfly(a, t << (log - bits), sign, wv[j0, re], wv[j0, im], wv[j1, re], wv[j1, im])
        wv[j0, re], wv[j0, im], wv[j1, re], wv[j1, im] = r0, i0, r1, i1


@ti.func
def _makhoul(j, m):
    """Where cell j goes in the transform's input: the even cells first, the odd ones backwards."""
    n = j >> 1
    if j & 1:
        n = m - 1 - n
    return n


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
    on,
):
    """``dst1 = F1 src1`` and ``dst2 = F2 src2`` for filters diagonal in the grid's cosine
    modes (their values per mode, with the transforms' scale, in columns ``sym1``, ``sym2``),
    in one FFT and one inverse FFT of M points: forward of ``v1 + i v2`` (``v`` the cells in
    Makhoul's order), each input's spectrum taken apart by conjugate symmetry and twisted into
    its cosine transform, filtered, and put back as ``exp(i pi m / 2M) (Y_m - i Y_{M-m})``,
    the spectrum of the output in the same order (Hermitian: a real output), the two packed
    as real and imaginary parts, back. Modes m and M - m are taken in one iteration.
    ``parallel``: every butterfly pass a loop of its own at the kernel's top level (unrolled
    up to the longest transform); else a loop over the passes, for a serial caller (the same
    arithmetic, far less code to compile). No loop runs when ``on`` is 0."""
    wv = ti.static(a.own)
    m = cells(a)
    for j in range(m * on):
        r = ti.cast(wv[_makhoul(j, m), Wave.REV], ti.i32)
        wv[r, Wave.RE] = wv[j, src1]
        wv[r, Wave.IM] = wv[j, src2]
    _fft(a, Wave.RE, Wave.IM, 1.0, False, parallel, on)
    for mode in range((m // 2 + 1) * on):
        other = (m - mode) & (m - 1)
        zr, zi, yr, yi = wv[mode, Wave.RE], wv[mode, Wave.IM], wv[other, Wave.RE], wv[other, Wave.IM]
        cr, ci = wv[mode, Wave.CR], wv[mode, Wave.CI]
        # the two inputs' transforms at this mode: (Z_m + conj Z_-m) / 2 and (Z_m - conj Z_-m) / 2i;
        # their cosine transforms at m and (by conjugate symmetry, twisted by the other's angle) at M - m
        a1, b1 = 0.5 * (zr + yr), 0.5 * (zi - yi)
        a2, b2 = 0.5 * (zi + yi), -0.5 * (zr - yr)
        y1 = wv[mode, sym1] * (cr * a1 + ci * b1)
        y2 = wv[mode, sym2] * (cr * a2 + ci * b2)
        y1o = 0.0
        y2o = 0.0
        if mode > 0:  # mode M is not a mode of the grid
            y1o = wv[other, sym1] * (ci * a1 - cr * b1)
            y2o = wv[other, sym2] * (ci * a2 - cr * b2)
        ur, ui = y1 + y2o, y2 - y1o
        r = ti.cast(wv[mode, Wave.REV], ti.i32)
        wv[r, Wave.QR] = cr * ur - ci * ui
        wv[r, Wave.QI] = cr * ui + ci * ur
        if mode > 0 and other != mode:
            vr, vi = y1o + y2, y2o - y1
            ro = ti.cast(wv[other, Wave.REV], ti.i32)
            wv[ro, Wave.QR] = ci * vr - cr * vi
            wv[ro, Wave.QI] = ci * vi + cr * vr
    _fft(a, Wave.QR, Wave.QI, -1.0, False, parallel, on)
    for j in range(m * on):
        n = _makhoul(j, m)
        wv[j, dst1] = wv[n, Wave.QR]
        wv[j, dst2] = wv[n, Wave.QI]


@ti.func
def apply_filter(a: ti.template(), src: ti.template(), sym: ti.template(), dst: ti.template(), parallel: ti.template(), on):
    """``dst = F src`` for one filter diagonal in the grid's cosine modes (as
    :func:`apply_filters`), through FFTs of M / 2 points: the M cells in Makhoul's order ``v``
    packed as ``v_2n + i v_2n+1``, transformed, the M-point spectrum of ``v`` taken apart
    from it (the real input's split), twisted, filtered and put back as the spectrum of the
    output in the same order, folded to M / 2 points the same way (the real output's
    merge), back. Modes k, M - k, M/2 + k and M/2 - k are taken in one iteration: half the
    work of a pair of filters for one. No loop runs when ``on`` is 0."""
    wv = ti.static(a.own)
    m = cells(a)
    n = m >> 1
    for q in range(n * on):
        r = ti.cast(wv[q, Wave.REV], ti.i32) >> 1  # q's log2(M/2) bits reversed
        wv[r, Wave.RE] = wv[_cell(2 * q, m), src]
        wv[r, Wave.IM] = wv[_cell(2 * q + 1, m), src]
    _fft(a, Wave.RE, Wave.IM, 1.0, True, parallel, on)
    for k in range((n // 2 + 1) * on):
        o = (n - k) & (n - 1)
        zr, zi, yr, yi = wv[k, Wave.RE], wv[k, Wave.IM], wv[o, Wave.RE], wv[o, Wave.IM]
        # the even and odd elements' transforms, E = (Z_k + conj Z_-k) / 2 and O = (Z_k - conj Z_-k) / 2i,
        # and the M-point spectrum V_k = E + t O, V_{n+k} = E - t O (t = exp(-2 pi i k / M))
        er, ei = 0.5 * (zr + yr), 0.5 * (zi - yi)
        odr, odi = 0.5 * (zi + yi), -0.5 * (zr - yr)
        tr, tw = wv[k, Wave.TWR], wv[k, Wave.TWI]
        pr, pi = tr * odr - tw * odi, tr * odi + tw * odr
        vr, vi = er + pr, ei + pi
        ur, ui = er - pr, ei - pi
        # the filtered cosine transform at modes k, n + k, and (conjugates) M - k, n - k
        y_k = wv[k, sym] * (wv[k, Wave.CR] * vr + wv[k, Wave.CI] * vi)
        y_nk = wv[n + k, sym] * (wv[n + k, Wave.CR] * ur + wv[n + k, Wave.CI] * ui)
        y_mk = 0.0  # mode M is not a mode of the grid
        y_n_k = y_nk  # mode n - 0 is mode n + 0
        if k > 0:
            y_mk = wv[m - k, sym] * (wv[m - k, Wave.CR] * vr - wv[m - k, Wave.CI] * vi)
            y_n_k = wv[n - k, sym] * (wv[n - k, Wave.CR] * ur - wv[n - k, Wave.CI] * ui)
        # the output's spectrum W_j = exp(i pi j / 2M) (Y_j - i Y_{M-j}) at j = k and n + k
        c_k, s_k = wv[k, Wave.CR], wv[k, Wave.CI]
        c_n, s_n = wv[n + k, Wave.CR], wv[n + k, Wave.CI]
        ar, ai = c_k * y_k + s_k * y_mk, s_k * y_k - c_k * y_mk
        br, bi = c_n * y_nk + s_n * y_n_k, s_n * y_nk - c_n * y_n_k
        # folded: F_k = (W_k + W_{n+k}) + i conj(t) (W_k - W_{n+k})
        dr, di = ar - br, ai - bi
        fr, fi = tr * dr + tw * di, tr * di - tw * dr
        r = ti.cast(wv[k, Wave.REV], ti.i32) >> 1
        wv[r, Wave.QR] = ar + br - fi
        wv[r, Wave.QI] = ai + bi + fr
        if k > 0 and o != k:
            # F_{n-k} from W_{n-k} = conj W_{n+k} and W_{M-k} = conj W_k, with -t in place of conj(t)
            dr, di = br - ar, ai - bi
            fr, fi = tr * dr - tw * di, tr * di + tw * dr
            ro = ti.cast(wv[o, Wave.REV], ti.i32) >> 1
            wv[ro, Wave.QR] = br + ar + fi
            wv[ro, Wave.QI] = -bi - ai - fr
    _fft(a, Wave.QR, Wave.QI, -1.0, True, parallel, on)
    for j in range(m * on):
        p = _makhoul(j, m)
        v = wv[p >> 1, Wave.QR]
        if p & 1:
            v = wv[p >> 1, Wave.QI]
        wv[j, dst] = v


@ti.func
def _cell(p, m):
    """The cell at place p of Makhoul's order (the inverse of :func:`_makhoul`)."""
    j = 2 * p
    if p >= m >> 1:
        j = 2 * (m - 1 - p) + 1
    return j


@ti.func
def refresh(a: ti.template()):
    """What the step keeps from the grid's state: ``G PHI`` and the surface at the depth of
    the icebergs' pressure, ``ETA_P = A ETA`` (at a kernel's top level: every loop parallel)."""
    apply_filters(a, Wave.PHI, Wave.KT, Wave.GPHI, Wave.ETA, Wave.AT, Wave.ETA_P, True, 1)


@ti.func
def kick_grid(fx: ti.template(), a: ti.template()):
    """``phi -= Dt g eta`` when a wave step opens (with the icebergs' kick: both from the
    surface at its opening)."""
    wv = ti.static(a.own)
    dt = wave_dt(a)
    for j in range(cells(a) * opens(a)):
        wv[j, Wave.PHI] -= dt * wv[j, Wave.ETA]


@ti.func
def _update(a: ti.template(), parallel: ti.template()):
    """``eta += Dt G phi + A q`` when a wave step closes: the displaced water enters as it
    was taken, through the depth filter ``A``; cleared for the next wave step."""
    on = closes(a)
    apply_filters(a, Wave.PHI, Wave.KT, Wave.GPHI, Wave.SRC, Wave.AT, Wave.SRC_P, parallel, on)
    wv = ti.static(a.own)
    dt = wave_dt(a)
    for j in range(cells(a) * on):
        wv[j, Wave.ETA] += dt * wv[j, Wave.GPHI] + wv[j, Wave.SRC_P]
        wv[j, Wave.SRC] = 0.0


@ti.func
def _pressure_surface(a: ti.template(), parallel: ti.template()):
    """``ETA_P = A ETA`` for the next wave step's kick, when a wave step closes; then the
    phase advances (the grid's step's last loop)."""
    apply_filter(a, Wave.ETA, Wave.AT, Wave.ETA_P, parallel, closes(a))
    for _ in range(1):
        nxt = phase(a) + 1
        if nxt == every(a):
            nxt = 0
        a.own[0, Wave.PHASE] = nxt


@ti.func
def update(fx: ti.template(), a: ti.template()):
    _update(a, True)


@ti.func
def pressure_surface(fx: ti.template(), a: ti.template()):
    _pressure_surface(a, True)


@ti.func
def sponge(fx: ti.template(), a: ti.template()):
    """The absorbing layer, ``eta <- eta / (1 + Dt sigma)``, each cell on its own (parallel:
    no loop over the grid on one thread). The energy it removes per cell (:func:`_absorb`)
    is rounded to a multiple of ``SPONGE_Q`` and the cells' shares added with atomics into
    ``red[0, 0]`` (f64 in any form; free after the correction): such sums are exact, so the
    step's total does not depend on the order of the additions (the same bits in every form,
    on any thread count and on a device); then one addition to ``wave_absorbed``. When a wave step closes, with ``Dt``."""
    for _ in range(1):
        a.red[0, 0] = ti.cast(0.0, ti.f64)
    for j in range(cells(a) * closes(a)):
        share = _absorb(a, j)
        if share != 0:
            ti.atomic_add(a.red[0, 0], share)
    for _ in range(1):
        a.acc[Acc.WAVE_ABSORBED] += a.red[0, 0]


@ti.func
def _absorb(a: ti.template(), j):
    """Cell j's relaxation in the absorbing layer; returns the energy it removed, rounded to
    a multiple of ``SPONGE_Q`` (f64): the change of the energy the grid's symplectic Euler
    conserves between reflecting ends, ``E_w - Dt/2 rho int eta G phi`` (``G phi`` of this
    wave step, set by :func:`_update`), so that this plus ``wave_absorbed`` holds whatever
    the wave step; ``E_w`` differs from it by a term that oscillates and vanishes with the
    waves."""
    wv = ti.static(a.own)
    share = ti.cast(0.0, ti.f64)
    sig = wv[j, Wave.SPONGE]
    if sig > 0:
        dt = wave_dt(a)
        e = wv[j, Wave.ETA]
        en = e / (1.0 + dt * sig)
        # the change of what the grid's step conserves, E_w - Dt/2 rho int eta G phi
        removed = (0.5 * (e + en) - 0.5 * dt * wv[j, Wave.GPHI]) * (e - en)
        share = quantize(ti.cast(removed * a.par[Param.WAVE_DX], ti.f64), SPONGE_Q)
        wv[j, Wave.ETA] = en
    return share


@ti.func
def _sponge_serial(a: ti.template()):
    """:func:`sponge` in one loop (the serial form): the shares summed in a local variable,
    the same exact sum (no atomics, which a fused launch's cached loads could miss)."""
    total = ti.cast(0.0, ti.f64)
    for j in range(cells(a) * closes(a)):
        total += _absorb(a, j)
    a.acc[Acc.WAVE_ABSORBED] += total

"""The wave grid's kernels: its step (``eta += dt G phi + q``, the absorbing layer) and ``phi``'s kick.

The physics and its discrete form are in :mod:`melange_ti.physics.effects.waves`. The grid's
step applies ``G`` through a cosine transform done as a complex FFT of length ``2M`` (the
even extension of the ``M`` cells, ``M`` a power of 2): bit-reversed load, ``log2(2M)``
butterfly stages, each a loop over ``M`` butterflies that write disjoint elements, so every
loop is parallel and its bits do not depend on the thread count; two real filters share one
complex transform (:func:`apply_filters`). Twiddles, the bit reversal and the operators'
symbols are computed once on the host (:mod:`.host`), so no kernel evaluates a
trigonometric function. The grid is the effect's table, ``a.own`` (namespace :class:`Wave`).
"""

import taichi as ti

from ...data.schema import Acc, Config, Param
from . import MAX_CELLS, SPONGE_Q, Wave

MAX_LOG = MAX_CELLS.bit_length()  # butterfly stages of the longest transform, 2 * MAX_CELLS


@ti.func
def cells(a: ti.template()):
    """The grid's cells, M."""
    return ti.cast(a.cfg[Config.WAVE_CELLS], ti.i32)


@ti.func
def quantize(v, quantum):
    return ti.floor(v / quantum + 0.5) * quantum


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
    wv = ti.static(a.own)
    m = cells(a)
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
    wv = ti.static(a.own)
    m = cells(a)
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
    wv = ti.static(a.own)
    dt = a.par[Param.DT]
    for j in range(cells(a)):
        wv[j, Wave.PHI] -= dt * wv[j, Wave.ETA]


@ti.func
def _update(a: ti.template(), parallel: ti.template()):
    """``eta += dt G phi + A q``: the displaced water enters as it was taken, through the
    depth filter ``A``; cleared for the next step."""
    apply_filters(a, Wave.PHI, Wave.KT, Wave.GPHI, Wave.SRC, Wave.AT, Wave.SRC_P, parallel)
    wv = ti.static(a.own)
    dt = a.par[Param.DT]
    for j in range(cells(a)):
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
    for _ in range(1):
        a.red[0, 0] = ti.cast(0.0, ti.f64)
    for j in range(cells(a)):
        share = _absorb(a, j)
        if share != 0:
            ti.atomic_add(a.red[0, 0], share)
    for _ in range(1):
        a.acc[Acc.WAVE_ABSORBED] += a.red[0, 0]


@ti.func
def _absorb(a: ti.template(), j):
    """Cell j's relaxation in the absorbing layer; returns the energy it removed, rounded to
    a multiple of ``SPONGE_Q`` (f64)."""
    wv = ti.static(a.own)
    share = ti.cast(0.0, ti.f64)
    sig = wv[j, Wave.SPONGE]
    if sig > 0:
        e = wv[j, Wave.ETA]
        en = e / (1.0 + a.par[Param.DT] * sig)
        share = quantize(ti.cast(0.5 * (e * e - en * en) * a.par[Param.WAVE_DX], ti.f64), SPONGE_Q)
        wv[j, Wave.ETA] = en
    return share


@ti.func
def _sponge_serial(a: ti.template()):
    """:func:`sponge` in one loop (the serial form): the shares summed in a local variable,
    the same exact sum (no atomics, which a fused launch's cached loads could miss)."""
    total = ti.cast(0.0, ti.f64)
    for j in range(cells(a)):
        total += _absorb(a, j)
    a.acc[Acc.WAVE_ABSORBED] += total


@ti.func
def waves_serial(fx: ti.template(), a: ti.template()):
    _update(a, False)
    _sponge_serial(a)
    _pressure_surface(a, False)

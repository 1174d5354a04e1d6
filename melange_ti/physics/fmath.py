"""Maths the device lacks: f64 ``sin`` and ``cos`` for Taichi's SPIR-V backends.

Taichi 1.7's SPIR-V code generator (Vulkan, Metal, OpenGL: the path of AMD, Intel and Apple
GPUs) compiles f64 ``+ - * / sqrt floor abs`` but not f64 ``sin`` or ``cos`` (GLSL's
extended instructions are 32-bit only). :func:`sin_cos` supplies them there, from those
operations alone: the argument reduced by ``pi/2`` in three parts (Cody and Waite, as
fdlibm's ``__ieee754_rem_pio2`` does for medium arguments), then fdlibm's minimax
polynomials on ``[-pi/4, pi/4]``. Valid for ``|x| < 2**20 * pi/2`` (about 1.6 million radians; a tilt never comes near),
within 1 ulp of numpy over the tilts the model meets (tested in tests/test_device.py).
Everywhere else (the CPU, CUDA, f32) :func:`..step.forces.orient` calls Taichi's own functions,
so the CPU's bits do not depend on this module.
"""

import taichi as ti

SPIRV_ARCHS = ("vulkan", "metal", "opengl", "gles", "dx11", "dx12")

# 2/pi, and pi/2 in three parts of 33 bits (each product with a whole number below 2**20 is
# exact), each with its tail (fdlibm, e_rem_pio2.c)
INV_PIO2 = 6.36619772367581382433e-01
PIO2_1 = 1.57079632673412561417e00
PIO2_1T = 6.07710050650619224932e-11
PIO2_2 = 6.07710050630396597660e-11
PIO2_2T = 2.02226624879595063154e-21
PIO2_3 = 2.02226624871116645580e-21
PIO2_3T = 8.47842766036889956997e-32
# below this share of |x| the reduced argument lost so many bits that pi/2's third part counts
THIRD_PART = 2.0**-45

# sin(x) ~ x + S1 x^3 + ... + S6 x^13 and cos(x) ~ 1 - x^2/2 + C1 x^4 + ... + C6 x^14 on
# [-pi/4, pi/4] (fdlibm, k_sin.c and k_cos.c)
S1, S2, S3 = -1.66666666666666324348e-01, 8.33333333332248946124e-03, -1.98412698298579493134e-04
S4, S5, S6 = 2.75573137070700676789e-06, -2.50507602534068634195e-08, 1.58969099521155010221e-10
C1, C2, C3 = 4.16666666666666019037e-02, -1.38888888888741095749e-03, 2.48015872894767294178e-05
C4, C5, C6 = -2.75573143513906633035e-07, 2.08757232129817482790e-09, -1.13596475577881948265e-11


def on_spirv() -> bool:
    """True while compiling for a SPIR-V backend (decided when a kernel compiles)."""
    return str(ti.lang.impl.current_cfg().arch).split(".")[-1] in SPIRV_ARCHS


def needs_own_trig() -> bool:
    """True while compiling for a SPIR-V backend in f64 (decided when a kernel compiles)."""
    return on_spirv() and ti.lang.impl.get_runtime().default_fp == ti.f64


@ti.func
def kernel_sin(x: ti.f64, y: ti.f64) -> ti.f64:
    """sin(x + y) for |x| <= pi/4, y the tail of the reduced argument."""
    z = x * x
    w = z * z
    r = S2 + z * (S3 + z * S4) + z * w * (S5 + z * S6)
    v = z * x
    return x - ((z * (0.5 * y - v * r) - y) - v * S1)


@ti.func
def kernel_cos(x: ti.f64, y: ti.f64) -> ti.f64:
    """cos(x + y) for |x| <= pi/4."""
    z = x * x
    w = z * z
    r = z * (C1 + z * (C2 + z * C3)) + w * w * (C4 + z * (C5 + z * C6))
    hz = 0.5 * z
    w = 1.0 - hz
    return w + (((1.0 - w) - hz) + (z * r - x * y))


@ti.func
def sin_cos_f64(x: ti.f64):
    """(sin x, cos x) from + - * floor alone."""
    fn = ti.floor(x * INV_PIO2 + 0.5)
    # y0 + y1 = x - fn * pi/2: pi/2's first part taken away exactly, the second with its
    # rounding error kept, the third only where that cancelled nearly everything (fdlibm)
    r = x - fn * PIO2_1
    t = r
    w = fn * PIO2_2
    r = t - w
    w = fn * PIO2_2T - ((t - r) - w)
    y0 = r - w
    if ti.abs(y0) < ti.abs(x) * THIRD_PART:
        t = r
        w = fn * PIO2_3
        r = t - w
        w = fn * PIO2_3T - ((t - r) - w)
        y0 = r - w
    y1 = (r - y0) - w
    s = kernel_sin(y0, y1)
    c = kernel_cos(y0, y1)
    q = ti.cast(fn, ti.i64) & 3
    sn, cs = s, c
    if q == 1:
        sn, cs = c, -s
    elif q == 2:
        sn, cs = -s, -c
    elif q == 3:
        sn, cs = -c, s
    return sn, cs

"""Exact hydrostatics of a rotated rectangle under a flat sea surface (Taichi functions).

The submerged part is the rectangle clipped at the water line. Its area ``A`` and first
moments ``Sx = int (x - x_G) dA``, ``Sz = int (z - z_G) dA`` (about the centre of mass) follow
from Green's theorem summed edge by edge over the clipped boundary: each edge below the water
contributes fully, an edge that crosses contributes its submerged piece, and the water-line
segment from the exit to the entry crossing closes the polygon. Units: widths, g = rho_w = 1.
"""

import taichi as ti


@ti.func
def _segment(px, pz, qx, qz):
    """Contribution of the directed segment p->q to (A, Sx, Sz) of a CCW polygon."""
    cross = px * qz - qx * pz
    return ti.Vector([0.5 * cross, cross * (px + qx) / 6.0, cross * (pz + qz) / 6.0])


@ti.func
def corner(k: ti.template(), hw, hh, c, s):
    """Corner ``k`` (CCW from the lower right in the body frame) relative to the centre."""
    su = ti.static((1.0, 1.0, -1.0, -1.0)[k])
    sv = ti.static((-1.0, 1.0, 1.0, -1.0)[k])
    return ti.Vector([su * hw * c - sv * hh * s, su * hw * s + sv * hh * c])


@ti.func
def submerged_moments(z, c, s, hw, hh, water_level):
    """(A, Sx, Sz) of the part of the rectangle below ``water_level``.

    ``z``: centre height; ``c``, ``s``: cosine and sine of the tilt (CCW); ``hw``, ``hh``:
    half width and half thickness. Moments are about the centre of mass, so the buoyancy
    torque is ``rho g Sx``.
    """
    level = water_level - z
    m = ti.Vector([0.0, 0.0, 0.0])
    exit_pt = ti.Vector([0.0, 0.0])
    entry_pt = ti.Vector([0.0, 0.0])
    crossed = 0
    for k in ti.static(range(4)):
        p = corner(k, hw, hh, c, s)
        q = corner((k + 1) % 4, hw, hh, c, s)
        p_wet = p[1] < level
        q_wet = q[1] < level
        if p_wet and q_wet:
            m += _segment(p[0], p[1], q[0], q[1])
        elif p_wet != q_wet:
            t = (level - p[1]) / (q[1] - p[1])
            cut = ti.Vector([p[0] + t * (q[0] - p[0]), level])
            if p_wet:
                m += _segment(p[0], p[1], cut[0], cut[1])
                exit_pt = cut
            else:
                m += _segment(cut[0], cut[1], q[0], q[1])
                entry_pt = cut
            crossed = 1
    if crossed:
        m += _segment(exit_pt[0], exit_pt[1], entry_pt[0], entry_pt[1])
    return m


@ti.func
def potential_energy(z, c, s, hw, hh, mass, water_level, gravity: ti.template(), buoyancy: ti.template()):
    """``U = m g (z_G - wl) - rho_w g int_sub (z - wl) dA`` for the effects named (docs/model.md);
    ``c``, ``s``: cosine and sine of the tilt."""
    u = 0.0
    if ti.static(gravity):
        u += mass * (z - water_level)
    if ti.static(buoyancy):
        m = submerged_moments(z, c, s, hw, hh, water_level)
        u -= m[2] + m[0] * (z - water_level)
    return u

"""The pair at a contact point: its relative velocity along a direction and its inverse
effective mass there, which the contact law (:mod:`.impulses`), an effect's own impulse
(friction's, :mod:`..effects.terms.friction`) and the correction (:mod:`.correction`) share."""

import taichi as ti

from ..data.schema import Body
from ..shape.discs import cross2
from .forces import contact_mass


@ti.func
def relative_normal(a: ti.template(), i, j, cx: ti.template(), cz: ti.template(), com: ti.template(), rx1, rz1, rx2, rz2, nx, nz):
    """Normal relative value at the contact of the velocity-like columns ``cx, cz, com`` of
    ``b``; j < 0 is the wall (zero)."""
    b = ti.static(a.b)
    v1x = b[i, cx] - b[i, com] * rz1
    v1z = b[i, cz] + b[i, com] * rx1
    v2x = 0.0
    v2z = 0.0
    if j >= 0:
        v2x = b[j, cx] - b[j, com] * rz2
        v2z = b[j, cz] + b[j, com] * rx2
    return (v1x - v2x) * nx + (v1z - v2z) * nz


@ti.func
def normal_speed(a: ti.template(), i, j, rx1, rz1, rx2, rz2, nx, nz):
    """Normal relative velocity at the contact; j < 0 is the wall (at rest)."""
    return relative_normal(a, i, j, Body.VX, Body.VZ, Body.OM, rx1, rz1, rx2, rz2, nx, nz)


@ti.func
def pair_mass(fx: ti.template(), a: ti.template(), i, j, rx1, rz1, rx2, rz2, dx, dz):
    """The pair's inverse effective mass along the unit direction ``d`` at the contact,
    ``K = 1/m_1 + 1/m_2 + (r_1 x d)^2 / I_1 + (r_2 x d)^2 / I_2`` (j < 0: the wall, infinite
    mass), with what :func:`push` needs: ``(K, m_1, I_1, r_1 x d, m_2, I_2, r_2 x d)``."""
    d = ti.Vector([dx, dz])
    c1 = cross2(ti.Vector([rx1, rz1]), d)
    m1, inv1, i1 = contact_mass(fx, a, i)
    k = inv1 + c1 * c1 / i1
    c2 = 0.0
    m2, i2 = 1.0, 1.0
    if j >= 0:
        c2 = cross2(ti.Vector([rx2, rz2]), d)
        m2, inv2, i2 = contact_mass(fx, a, j)
        k += inv2 + c2 * c2 / i2
    return k, m1, i1, c1, m2, i2, c2

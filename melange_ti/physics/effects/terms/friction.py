"""The friction effect's term (declared in :mod:`..friction`): the contact law's impulse
with Coulomb's cone, in place of the frictionless one of :func:`...step.impulses.resolve`."""

import taichi as ti

from ...data.schema import Body, Param
from ...step.pairs import pair_mass, relative_normal

# Bisection steps for the restitution an impact may keep without creating energy (the kinetic
# energy change changes sign once over [0, e]: docs/model.md, "An impact never creates energy");
# 60 halvings of [0, e] leave e' to within 1e-18
PROJECTION_STEPS = 60


@ti.func
def coulomb(vn, vt, e, knn, knt, ktt, mu):
    """``(J_n, J_t)`` of Newton's restitution ``e`` with Coulomb's cone at a contact point whose
    relative velocity ``(v_n, v_t)`` changes by ``K J`` (docs/model.md, Friction)."""
    dvn = -(1.0 + e) * vn  # the normal velocity change restitution asks for
    # stick: K P = (dvn, -v_t), solved through the tangential Schur complement (> 0: K is positive definite)
    jt = -(vt + knt * dvn / knn) / (ktt - knt * knt / knn)
    jn = (dvn - knt * jt) / knn
    if ti.abs(jt) > mu * jn:  # outside the cone: slide on its edge on jt's side (mu = 0: the frictionless J_n)
        side = 1.0 if jt > 0 else -1.0
        jn = dvn / (knn + side * mu * knt)  # > 0 here: the stick impulse lies outside the cone on this side
        jt = side * mu * jn
    return jn, jt


@ti.func
def gain(jn, jt, vn, vt, knn, knt, ktt):
    """The kinetic energy the impulse ``(J_n, J_t)`` gives the pair: ``J . u + J . K J / 2``."""
    return jn * vn + jt * vt + 0.5 * (knn * jn * jn + 2.0 * knt * jn * jt + ktt * jt * jt)


@ti.func
def impulse(
    fx: ti.template(), a: ti.template(), i, j, rx1, rz1, rx2, rz2, nx, nz, vn, e, knn, m1, i1, c1n, m2, i2, c2n, kick_vn, room
):
    """The impulse ``P = J_n n + J_t t`` of Newton's restitution with Coulomb friction
    (effect ``friction``, :mod:`..friction`; derived in docs/model.md), applied to
    the pair: the contact point's relative velocity ``u = (v_n, v_t)`` changes by ``K P``,
    ``K`` the 2x2 effective-mass matrix of the point (``K_nt`` couples the two directions
    at an off-centre contact). ``v_n' = -e v_n`` always; the contact sticks (``v_t' = 0``)
    when that impulse lies in the cone ``|J_t| <= mu J_n``, else it slides along the cone's
    edge on that side. Returns ``J_n`` and the terms of the law's ledgers
    (:func:`...data.schema.law_ledgers`): the normal impulse's dissipation, the half-kick offset,
    the tangential impulse's dissipation; each impulse's work at its direction's mean
    velocity, ``-J (v + v') / 2``, which sum to the kinetic energy lost.

    With crushing (effect ``crushing``) an impulse whose ``J_n`` exceeds ``room``, what the
    contact may still pass this step, is scaled down whole to ``J_n = room``: it stays in the
    cone, and its kinetic-energy gain ``s J . u + s^2 J . K J / 2`` is convex in the scale
    ``s``, so over ``[0, 1]`` at most the unscaled impulse's (no gain, above): a crushing
    contact creates no energy either."""
    tx = -nz
    tz = nx
    ktt, _m1, _i1, c1t, _m2, _i2, c2t = pair_mass(fx, a, i, j, rx1, rz1, rx2, rz2, tx, tz)
    knt = c1n * c1t / i1
    if j >= 0:
        knt += c2n * c2t / i2
    vt = relative_normal(a, i, j, Body.VX, Body.VZ, Body.OM, rx1, rz1, rx2, rz2, tx, tz)
    mu = a.par[Param.FRICTION]
    jn, jt = coulomb(vn, vt, e, knn, knt, ktt, mu)
    kept = e  # the restitution the impulse keeps
    # a gain past rounding (64 epsilons of the normal impact's energy scale; Newton's law at e = 1
    # without friction gains exactly 0, and rounding alone must not start a projection)
    noise = 64.0 * a.par[Param.EPS] * 0.5 * vn * vn / knn
    if gain(jn, jt, vn, vt, knn, knt, ktt) > noise:
        # Newton's restitution with the cone would create energy (an off-centre contact that
        # sticks, e near 1): the largest e' <= e whose impulse does not (docs/model.md, "An impact
        # never creates energy"); the gain changes sign once over [0, e], so bisection finds it
        lo = 0.0 * e
        hi = e
        for _ in range(PROJECTION_STEPS):
            mid = 0.5 * (lo + hi)
            tn, tt = coulomb(vn, vt, mid, knn, knt, ktt, mu)
            if gain(tn, tt, vn, vt, knn, knt, ktt) > 0.0:
                hi = mid
            else:
                lo = mid
        kept = lo
        jn, jt = coulomb(vn, vt, lo, knn, knt, ktt, mu)

    scaled = False
    if ti.static(fx.crushing):
        if jn > room:
            jt *= room / jn
            jn = room
            scaled = True
    px = jn * nx + jt * tx
    pz = jn * nz + jt * tz
    b = ti.static(a.b)
    b[i, Body.VX] += px / m1
    b[i, Body.VZ] += pz / m1
    b[i, Body.OM] += (c1n * jn + c1t * jt) / i1
    if j >= 0:
        b[j, Body.VX] -= px / m2
        b[j, Body.VZ] -= pz / m2
        b[j, Body.OM] -= (c2n * jn + c2t * jt) / i2
    vn_after = vn + knn * jn + knt * jt
    vt_after = vt + knt * jn + ktt * jt
    collision = -0.5 * jn * (vn + vn_after)
    if jt == 0.0 and not scaled:  # the frictionless impulse (mu = 0, or no sliding to stop): its ledger's bits too
        collision = 0.5 * (1.0 - kept * kept) * vn * vn / knn
    kick_vt = relative_normal(a, i, j, Body.KICK_VX, Body.KICK_VZ, Body.KICK_OM, rx1, rz1, rx2, rz2, tx, tz)
    return jn, ti.Vector([collision, 0.5 * jn * kick_vn + 0.5 * jt * kick_vt, -0.5 * jt * (vt + vt_after)])

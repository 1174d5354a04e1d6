"""Forces and integration: the kick (body forces, then damping) and the drift.

Semi-implicit Euler, velocities first: ``v += dt F/m``, ``omega += dt tau/I`` from the
forces of the effects named (:data:`..effects.FORCES`, summed in registry order), then each
named damping term (:data:`..effects.DAMPERS`); after contacts, ``x += dt v`` and
``theta += dt omega``. When the scene has contacts the kick keeps the forces' change of the
velocities (``Body.KICK_VX``, ``KICK_VZ``, ``KICK_OM``; taken before the dampers, whose
change is in their own ledgers) for the impulses' energy booking, less the kick of the forces
whose effect books that share itself (``own_offset``: the bonds).
The drift caches cos and sin of the new tilt (``Body.COS``, ``Body.SIN``), the one place a
step evaluates trigonometric functions.
"""

import taichi as ti

from .. import fmath
from ..data.schema import Body, Param
from ..effects import ADDED, AFTER_KICK, DAMPERS, FORCES, OFFSET_KICK, POST_DRIFT, POTENTIALS, PRE_DRIFT, SUBSTEPPED
from .terms import term

HAS_TORQUE = tuple(e for e in FORCES if e.torque)
HORIZONTAL = tuple(e for e in FORCES if e.horizontal)
OWN_OFFSET = tuple(e for e in FORCES if e.own_offset)
assert all(e.horizontal and e.torque for e in OWN_OFFSET), "kick() leaves out all three components"


def any_on(effects, fx) -> bool:
    """Whether ``fx`` names any of ``effects`` (for ``ti.static``)."""
    return any(e.on(fx) for e in effects)


@ti.func
def added_inertia(fx: ti.template(), a: ti.template(), i):
    """The iceberg's mass and moment of inertia with what the named effects add (the water
    it carries); exactly its own columns when none adds any."""
    m = a.b[i, Body.MASS]
    inertia = a.b[i, Body.INERTIA]
    for e in ti.static(ADDED):
        if ti.static(e.on(fx)):
            extra = ti.static(term(e, "added_inertia"))(a, i)
            m += extra[0]
            inertia += extra[1]
    return m, inertia


@ti.func
def contact_mass(fx: ti.template(), a: ti.template(), i):
    """(mass, 1 / mass, moment of inertia) the contact law and the correction use: the
    iceberg's, plus the added inertia stored at this step's kick when an effect adds any."""
    m = a.b[i, Body.MASS]
    inv = a.b[i, Body.INV_MASS]
    inertia = a.b[i, Body.INERTIA]
    if ti.static(any_on(ADDED, fx)):
        m += a.b[i, Body.ADDED_M]
        inv = 1.0 / m
        inertia += a.b[i, Body.ADDED_I]
    return m, inv, inertia


@ti.func
def kick(fx: ti.template(), a: ti.template(), i):
    b = ti.static(a.b)
    dt = a.par[Param.DT]
    m, inertia = added_inertia(fx, a, i)
    v0 = ti.Vector([b[i, Body.VX], b[i, Body.VZ], b[i, Body.OM]])
    fxs = 0.0
    fz = 0.0
    tau = 0.0
    own = ti.Vector([0.0, 0.0, 0.0])  # the forces whose effect books its impulses' offset itself
    for e in ti.static(FORCES):
        if ti.static(e.on(fx)):
            f = ti.static(term(e, "force"))(a, i)  # (f_x, f_z, tau)
            if ti.static(e.horizontal):
                fxs += f[0]
            fz += f[1]
            if ti.static(e.torque):
                tau += f[2]
            if ti.static(e.own_offset):
                own += f
    if ti.static(any_on(HORIZONTAL, fx)):
        b[i, Body.VX] += dt * fxs / m
    if ti.static(any_on(FORCES, fx)):
        b[i, Body.VZ] += dt * fz / m
    if ti.static(any_on(HAS_TORQUE, fx)):
        b[i, Body.OM] += dt * tau / inertia
    # the half kick: the kinetic energy at the step time is the product of the velocities before
    # and after the forces' kick, 0.5 m v0 . (v0 + dv), i.e. that of v0 plus this (docs/model.md,
    # "What the budget promises"); the diagnostics read it, the step never does
    b[i, Body.HALF_KICK] = 0.5 * dt * (fxs * v0[0] + fz * v0[1] + tau * v0[2])
    for e in ti.static(AFTER_KICK):
        if ti.static(e.on(fx)):
            ti.static(term(e, "after_kick"))(a, i)
    if ti.static(fx.collisions or fx.wall):
        # the forces' change of the velocities, for the impulses' energy booking (impulses.py):
        # before the dampers, which book their own (docs/model.md, the impulses' half-kick offset)
        b[i, Body.KICK_VX] = b[i, Body.VX] - v0[0]
        b[i, Body.KICK_VZ] = b[i, Body.VZ] - v0[1]
        b[i, Body.KICK_OM] = b[i, Body.OM] - v0[2]
        for e in ti.static(OFFSET_KICK):  # a force kicking less often: its offset over its own step
            if ti.static(e.on(fx)):
                g = ti.static(term(e, "offset_kick"))(a, i)
                b[i, Body.KICK_VX] += dt * g[0] / m
                b[i, Body.KICK_VZ] += dt * g[1] / m
                b[i, Body.KICK_OM] += dt * g[2] / inertia
        if ti.static(any_on(OWN_OFFSET, fx)):
            # booked by that effect (bond_offset_work counts the impulses' change of velocity):
            # counted here too, an impulse's offset was booked twice (docs/bonds.md, Energy)
            b[i, Body.KICK_VX] -= dt * own[0] / m
            b[i, Body.KICK_VZ] -= dt * own[1] / m
            b[i, Body.KICK_OM] -= dt * own[2] / inertia
    for e in ti.static(DAMPERS):
        if ti.static(e.on(fx)):
            ti.static(term(e, "damp"))(a, i, m, inertia)


@ti.func
def orient(a: ti.template(), i):
    """Cache cos and sin of body i's tilt: the one place a step evaluates them (in f64 on a
    SPIR-V device, which has no f64 ``sin``/``cos``, from :mod:`..fmath`)."""
    if ti.static(fmath.needs_own_trig()):
        sn, cs = fmath.sin_cos_f64(a.b[i, Body.TH])
        a.b[i, Body.COS] = cs
        a.b[i, Body.SIN] = sn
    else:
        a.b[i, Body.COS] = ti.cos(a.b[i, Body.TH])
        a.b[i, Body.SIN] = ti.sin(a.b[i, Body.TH])


@ti.func
def move(a: ti.template(), i, dt):
    """``x += dt v``, ``theta += dt omega``, and the new tilt's cos and sin."""
    b = ti.static(a.b)
    b[i, Body.X] += dt * b[i, Body.VX]
    b[i, Body.Z] += dt * b[i, Body.VZ]
    b[i, Body.TH] += dt * b[i, Body.OM]
    orient(a, i)


@ti.func
def drift(fx: ti.template(), a: ti.template(), i):
    """The drift; when a named effect sub-steps it (``Effect.substeps``, ``fx.substepped``: ``n`` >
    1) its first sub-step of ``dt / n``, the others in :func:`substep`."""
    dt = a.par[Param.DT]
    for e in ti.static(PRE_DRIFT):
        if ti.static(e.on(fx)):
            ti.static(term(e, "pre_drift"))(a, i)
    if ti.static(fx.substepped):
        move(a, i, dt / a.par[Param.SUBSTEPS])  # post_drift after the last sub-step (stages.SUBSTEPS)
    else:
        move(a, i, dt)
        post_drift(fx, a, i)


@ti.func
def post_drift(fx: ti.template(), a: ti.template(), i):
    for e in ti.static(POST_DRIFT):
        if ti.static(e.on(fx)):
            ti.static(term(e, "post_drift"))(a, i)


@ti.func
def substep(fx: ti.template(), a: ti.template(), i):
    """One more sub-step of the drift (``h = dt / n``): the sub-stepped effects' forces (set by
    their ``substep_update`` at these positions; each gives its force over ``n``, so ``dt``
    times it is ``h`` times the force) kick the velocities, with the iceberg's mass and what is
    added to it at this step's kick, then their damping, then ``x += h v``. No other force
    acts between: every other force, and the contacts, act once a step."""
    b = ti.static(a.b)
    dt = a.par[Param.DT]
    m, _, inertia = contact_mass(fx, a, i)
    for e in ti.static(SUBSTEPPED):
        if ti.static(e.on(fx)):
            f = ti.static(term(e, "force"))(a, i)
            if ti.static(e.horizontal):
                b[i, Body.VX] += dt * f[0] / m
            b[i, Body.VZ] += dt * f[1] / m
            if ti.static(e.torque):
                b[i, Body.OM] += dt * f[2] / inertia
            ti.static(term(e, "substep_damp"))(a, i, m, inertia)
    move(a, i, dt / a.par[Param.SUBSTEPS])


@ti.func
def potential_energy(fx: ti.template(), a: ti.template(), i):
    """Potential energy of body i: the sum of the named effects' terms (docs/model.md)."""
    u = 0.0
    for e in ti.static(POTENTIALS):
        if ti.static(e.on(fx)):
            u += ti.static(term(e, "potential"))(a, i)
    return u


@ti.func
def kinetic_energy(fx: ti.template(), a: ti.template(), i):
    """Kinetic energy of iceberg i, and of the water it carries when an effect adds inertia."""
    b = ti.static(a.b)
    m, inertia = added_inertia(fx, a, i)
    return 0.5 * m * (b[i, Body.VX] ** 2 + b[i, Body.VZ] ** 2) + 0.5 * inertia * b[i, Body.OM] ** 2

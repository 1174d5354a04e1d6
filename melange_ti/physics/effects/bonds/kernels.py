"""The bonds' Taichi side: the stage that updates every bond at the step's start (its
forces, its dashpot, whether it breaks), and the terms that hand them to the icebergs.

Each bond is updated by one thread (the stage's loop over the bond table is parallel in the
parallel forms and on a device), writing only its own row; each iceberg then gathers its
bonds' forces in its own slot order (``Body.BOND_1`` ...): no two threads write one value
and no sum depends on the thread count, so every form gives the same bits. The physics is
in :mod:`melange_ti.physics.effects.bonds`.
"""

import taichi as ti

from ...data.schema import Body, Config, Param
from ...step.parts import Part, Stage, contacts
from . import MAX_BONDS, Bond


@ti.func
def points(a: ti.template(), r):
    """Bond r's bodies and geometry now: ``(i, j, rax, raz, nx, nz, rbx, rbz, pbx, pbz)``, A's
    arm and the bond's normal in the world frame, B's arm and point (the wall, j < 0: its
    fixed point, no arm)."""
    own = ti.static(a.own)
    b = ti.static(a.b)
    i = ti.cast(own[r, Bond.A], ti.i32)
    j = ti.cast(own[r, Bond.B], ti.i32)
    ca, sa = b[i, Body.COS], b[i, Body.SIN]
    rax = ca * own[r, Bond.UA] - sa * own[r, Bond.VA]
    raz = sa * own[r, Bond.UA] + ca * own[r, Bond.VA]
    nx = ca * own[r, Bond.NU] - sa * own[r, Bond.NV]
    nz = sa * own[r, Bond.NU] + ca * own[r, Bond.NV]
    rbx, rbz = 0.0, 0.0
    pbx, pbz = own[r, Bond.UB], own[r, Bond.VB]
    if j >= 0:
        cb, sb = b[j, Body.COS], b[j, Body.SIN]
        rbx = cb * own[r, Bond.UB] - sb * own[r, Bond.VB]
        rbz = sb * own[r, Bond.UB] + cb * own[r, Bond.VB]
        pbx = b[j, Body.X] + rbx
        pbz = b[j, Body.Z] + rbz
    return i, j, rax, raz, nx, nz, rbx, rbz, pbx, pbz


@ti.func
def step_of(a: ti.template()):
    """``h = dt / n``: the step the bonds' forces kick with (``physics.bond_substeps``; ``dt``, not
    divided, when 1: ``a.fx.substepped`` off)."""
    h = a.par[Param.DT]
    if ti.static(a.fx.substepped):
        h = h / a.par[Param.SUBSTEPS]
    return h


@ti.func
def update(a: ti.template(), r, check: ti.template()):
    """Bond ``r`` at the step's start (``check``): breaks it if its stress exceeds its strength
    (booking the energy it held in ``REL``), else sets its elastic and dashpot forces; at a
    later sub-step (not ``check``) only sets them."""
    own = ti.static(a.own)
    b = ti.static(a.b)
    if ti.static(check):
        own[r, Bond.REL] = 0.0
    gx, gz, ta, tb = 0.0, 0.0, 0.0, 0.0
    dxf, dzf, da, db = 0.0, 0.0, 0.0, 0.0
    if own[r, Bond.INTACT] > 0.5:
        i, j, rax, raz, nx, nz, rbx, rbz, pbx, pbz = points(a, r)
        sx, sz = -nz, nx
        # B's velocity and tilt (the wall: at rest, untilted)
        vbx, vbz, omb, thb = 0.0, 0.0, 0.0, 0.0
        if j >= 0:
            omb = b[j, Body.OM]
            vbx = b[j, Body.VX] - omb * rbz
            vbz = b[j, Body.VZ] + omb * rbx
            thb = b[j, Body.TH]
        oma = b[i, Body.OM]
        dx = pbx - (b[i, Body.X] + rax)
        dz = pbz - (b[i, Body.Z] + raz)
        dn = dx * nx + dz * nz
        ds = dx * sx + dz * sz
        dth = thb - b[i, Body.TH] - own[r, Bond.DTH]
        kn, ks, kb = own[r, Bond.KN], own[r, Bond.KS], own[r, Bond.KB]
        t = own[r, Bond.LEN]
        fn = kn * dn
        fs = ks * ds
        m = kb * dth
        sig = fn / t + 6.0 * ti.abs(m) / (t * t)
        tau = ti.abs(fs) / t
        gx = fn * nx + fs * sx
        gz = fn * nz + fs * sz
        ta = rax * gz - raz * gx - (kn - ks) * dn * ds + m
        tb = -(rbx * gz - rbz * gx) - m
        # in tension by its strength; at a crack's tip (fracture_energy on) by the energy that opens it (mode I:
        # its stretch, if stretched, and its bending; its shear is mode II, left to the shear strength)
        if ti.static(check):
            own[r, Bond.PEAK_SIG] = ti.max(own[r, Bond.PEAK_SIG], sig)
            own[r, Bond.PEAK_TAU] = ti.max(own[r, Bond.PEAK_TAU], tau)
        tensile = sig > own[r, Bond.ST]
        if own[r, Bond.GCL] > 0.0:
            if own[r, Bond.TIP] > 0.5:
                tensile = False
                if sig > 0.0:
                    tensile = 0.5 * (fn * ti.max(dn, 0.0) + m * dth) >= own[r, Bond.GCL]
        if ti.static(not check):
            tensile = False
            tau = 0.0
        if tensile or tau > own[r, Bond.SS]:
            own[r, Bond.INTACT] = 0.0
            own[r, Bond.BREAK_SIG] = sig
            own[r, Bond.BREAK_TAU] = tau
            # the energy it held as the step keeps it, U - dt/2 dU/dt (the bonds' docstring)
            vbcx, vbcz = 0.0, 0.0
            if j >= 0:
                vbcx, vbcz = b[j, Body.VX], b[j, Body.VZ]
            work = gx * (b[i, Body.VX] - vbcx) + gz * (b[i, Body.VZ] - vbcz) + ta * oma + tb * omb
            own[r, Bond.REL] = 0.5 * (fn * dn + fs * ds + m * dth) + 0.5 * step_of(a) * work
            gx, gz, ta, tb = 0.0, 0.0, 0.0, 0.0
        else:
            # the dashpot on the relative velocity of the two points, and of the tilts
            vrx = vbx - (b[i, Body.VX] - oma * raz)
            vrz = vbz - (b[i, Body.VZ] + oma * rax)
            vn = vrx * nx + vrz * nz
            vs = vrx * sx + vrz * sz
            cn = own[r, Bond.CN] * vn
            cs = own[r, Bond.CS] * vs
            cw = own[r, Bond.CB] * (omb - oma)
            dxf = cn * nx + cs * sx
            dzf = cn * nz + cs * sz
            # at the two points' midpoint on both bodies: no net torque (angular momentum kept)
            max_, maz = rax + 0.5 * dx, raz + 0.5 * dz
            mbx, mbz = rbx - 0.5 * dx, rbz - 0.5 * dz
            if j < 0:
                mbx, mbz = 0.0, 0.0
            da = max_ * dzf - maz * dxf + cw
            db = -(mbx * dzf - mbz * dxf) - cw
            if ti.static(check):
                own[r, Bond.AGE] += 1.0
    own[r, Bond.GX] = gx
    own[r, Bond.GZ] = gz
    own[r, Bond.TA] = ta
    own[r, Bond.TB] = tb
    own[r, Bond.DX] = dxf
    own[r, Bond.DZ] = dzf
    own[r, Bond.DA] = da
    own[r, Bond.DB] = db


@ti.func
def rows(a: ti.template()):
    """The bond table's rows in the owners' table ``a.own``: ``range(lo, hi)`` (after the rows of
    any owner before the bonds in the registry; docs/architecture.md)."""
    lo = ti.cast(a.cfg[Config.BONDS_ROW0], ti.i32)
    return lo, lo + ti.cast(a.cfg[Config.BONDS_ROWS], ti.i32)


@ti.func
def update_all(fx: ti.template(), a: ti.template()):
    """The stage: every bond (parallel over bonds in the parallel forms)."""
    lo, hi = rows(a)
    for r in range(lo, hi):
        update(a, r, True)


@ti.func
def substep_update(fx: ti.template(), a: ti.template()):
    """At a later sub-step of the drift: every intact bond's forces and dashpot at the
    sub-step's positions and velocities (no break check; parallel over bonds)."""
    lo, hi = rows(a)
    for r in range(lo, hi):
        update(a, r, False)


@ti.func
def _gather(a: ti.template(), i, fx_col: ti.template(), fz_col: ti.template(), ta_col: ti.template(), tb_col: ti.template()):
    """Body i's share of its bonds' columns (A: ``+F``, ``TA``; B: ``-F``, ``TB``), in slot order."""
    f = ti.Vector([0.0, 0.0, 0.0])
    for k in ti.static(range(MAX_BONDS)):
        r = ti.cast(a.b[i, Body.BOND_1 + k], ti.i32) - 1
        if r >= 0:
            if ti.cast(a.own[r, Bond.A], ti.i32) == i:
                f += ti.Vector([a.own[r, fx_col], a.own[r, fz_col], a.own[r, ta_col]])
            else:
                f += ti.Vector([-a.own[r, fx_col], -a.own[r, fz_col], a.own[r, tb_col]])
    return f


@ti.func
def force(a: ti.template(), i):
    """The elastic forces and torques of body i's bonds (set by :func:`update` this step), over
    the sub-steps ``n``: the kick's ``dt`` times it is ``h`` times the force (``n`` = 1: exactly
    the force)."""
    f = _gather(a, i, Bond.GX, Bond.GZ, Bond.TA, Bond.TB)
    if ti.static(a.fx.substepped):
        f = f / a.par[Param.SUBSTEPS]
    return f


@ti.func
def after_kick(a: ti.template(), i):
    """The body's velocities right after the forces' kick, for :func:`pre_drift`'s booking."""
    b = ti.static(a.b)
    b[i, Body.BOND_V0X] = b[i, Body.VX]
    b[i, Body.BOND_V0Z] = b[i, Body.VZ]
    b[i, Body.BOND_V0W] = b[i, Body.OM]


@ti.func
def _dashpots(a: ti.template(), i, m, inertia):
    """The dashpots' kick on body i (over ``h``), the kinetic energy it removes booked in
    ``BOND_DAMPED``; returns the change of (vx, vz, omega)."""
    b = ti.static(a.b)
    dt = step_of(a)
    d = _gather(a, i, Bond.DX, Bond.DZ, Bond.DA, Bond.DB)
    vx, vz, om = b[i, Body.VX], b[i, Body.VZ], b[i, Body.OM]
    nvx = vx + dt * d[0] / m
    nvz = vz + dt * d[1] / m
    nom = om + dt * d[2] / inertia
    b[i, Body.VX] = nvx
    b[i, Body.VZ] = nvz
    b[i, Body.OM] = nom
    # v^2 - v'^2 as (v - v') (v + v'): the dashpots' small change of a large velocity loses no digits
    linear = (vx - nvx) * (vx + nvx) + (vz - nvz) * (vz + nvz)
    b[i, Body.BOND_DAMPED] += 0.5 * m * linear + 0.5 * inertia * (om - nom) * (om + nom)
    return nvx - vx, nvz - vz, nom - om


@ti.func
def damp(a: ti.template(), i, m, inertia):
    """The dashpots' kick on body i after the forces; the kinetic energy it removes is booked
    exactly in ``BOND_DAMPED``, and the energy of its bonds that broke this step in
    ``BOND_RELEASED``."""
    b = ti.static(a.b)
    _dashpots(a, i, m, inertia)
    rel = 0.0
    for k in ti.static(range(MAX_BONDS)):
        r = ti.cast(b[i, Body.BOND_1 + k], ti.i32) - 1
        if r >= 0:
            share = 0.5
            if a.own[r, Bond.B] < 0.0:
                share = 1.0
            rel += share * a.own[r, Bond.REL]
    b[i, Body.BOND_RELEASED] += rel


@ti.func
def pre_drift(a: ti.template(), i):
    """The offset: the bonds' energy as the step keeps it, ``U + h/2 F . v``, changes by
    ``h/2 F . dv`` when anything after the forces' kick changes the body's velocity (the
    dashpot, drag, impulses), which those terms' own ledgers, counting kinetic energy, do not
    see: booked in ``BOND_OFFSET`` as ``h/2 F . (v_new - v_kicked)``, before the drift (its
    sub-steps kick the velocities again). (The forces' kick itself is the step's own: the
    energy it conserves.)"""
    b = ti.static(a.b)
    f = _gather(a, i, Bond.GX, Bond.GZ, Bond.TA, Bond.TB)
    dv = ti.Vector(
        [b[i, Body.VX] - b[i, Body.BOND_V0X], b[i, Body.VZ] - b[i, Body.BOND_V0Z], b[i, Body.OM] - b[i, Body.BOND_V0W]]
    )
    b[i, Body.BOND_OFFSET] += 0.5 * step_of(a) * f.dot(dv)
    if ti.static(a.fx.substepped):  # from here the sum of the sub-steps' drift velocities (DRIFT_SUM)
        b[i, Body.BOND_V0X] = b[i, Body.VX]
        b[i, Body.BOND_V0Z] = b[i, Body.VZ]
        b[i, Body.BOND_V0W] = b[i, Body.OM]


# with sub-steps, after the step's first drift: the columns that sum the velocities each sub-step
# drifted with (the overlap correction's predicted gaps read the step's displacement from them)
DRIFT_SUM = (Body.BOND_V0X, Body.BOND_V0Z, Body.BOND_V0W)


@ti.func
def substep_damp(a: ti.template(), i, m, inertia):
    """At a later sub-step, after the kick of the bonds' forces: their dashpots (booked in
    ``BOND_DAMPED``) and the offset their change of velocity makes in the bonds' energy as the
    sub-step keeps it, ``h/2 F . dv`` (as :func:`pre_drift`); then adds the velocity the sub-step
    drifts with to :data:`DRIFT_SUM`."""
    b = ti.static(a.b)
    dvx, dvz, dom = _dashpots(a, i, m, inertia)
    f = _gather(a, i, Bond.GX, Bond.GZ, Bond.TA, Bond.TB)
    b[i, Body.BOND_OFFSET] += 0.5 * step_of(a) * f.dot(ti.Vector([dvx, dvz, dom]))
    b[i, Body.BOND_V0X] += b[i, Body.VX]  # the velocity this sub-step drifts with (DRIFT_SUM)
    b[i, Body.BOND_V0Z] += b[i, Body.VZ]
    b[i, Body.BOND_V0W] += b[i, Body.OM]


@ti.func
def post_drift(a: ti.template(), i):
    """After the drift: the crack tips (:func:`_tips`)."""
    _tips(a, i)


@ti.func
def _tips(a: ti.template(), i):
    """Body i's bonds of which it is A (one writer each) become a crack's tip once a bond next
    to them along their face's line has broken (``NB1``, ``NB2``) while the bond that joins
    their ice where the two faces meet holds (``BR1``, ``BR2``: a crack does not jump a gap):
    read at the next step's break check, so no bond reads another's state as the same loop
    writes it."""
    own = ti.static(a.own)
    lo, _ = rows(a)
    for k in ti.static(range(MAX_BONDS)):
        r = ti.cast(a.b[i, Body.BOND_1 + k], ti.i32) - 1
        if r >= 0:
            if own[r, Bond.GCL] > 0.0 and own[r, Bond.TIP] < 0.5 and ti.cast(own[r, Bond.A], ti.i32) == i:
                for q, via in ti.static(((Bond.NB1, Bond.BR1), (Bond.NB2, Bond.BR2))):
                    nb = ti.cast(own[r, q], ti.i32)
                    br = ti.cast(own[r, via], ti.i32)
                    if nb >= 0:
                        if br >= 0:
                            if own[lo + nb, Bond.INTACT] < 0.5:
                                if own[lo + br, Bond.INTACT] > 0.5:
                                    own[r, Bond.TIP] = 1.0


@ti.func
def held_energy(a: ti.template(), r):
    """Bond r's energy as the step keeps it now, ``U - dt/2 dU/dt`` (0 if broken): the
    formula of :func:`update`, from the current state."""
    own = ti.static(a.own)
    b = ti.static(a.b)
    out = 0.0
    if own[r, Bond.INTACT] > 0.5:
        i, j, rax, raz, nx, nz, rbx, rbz, pbx, pbz = points(a, r)
        vbx, vbz, omb, thb = 0.0, 0.0, 0.0, 0.0
        if j >= 0:
            vbx, vbz, omb, thb = b[j, Body.VX], b[j, Body.VZ], b[j, Body.OM], b[j, Body.TH]
        dx = pbx - (b[i, Body.X] + rax)
        dz = pbz - (b[i, Body.Z] + raz)
        dn = dx * nx + dz * nz
        ds = -dx * nz + dz * nx
        dth = thb - b[i, Body.TH] - own[r, Bond.DTH]
        fn, fs, m = own[r, Bond.KN] * dn, own[r, Bond.KS] * ds, own[r, Bond.KB] * dth
        gx = fn * nx - fs * nz
        gz = fn * nz + fs * nx
        ta = rax * gz - raz * gx - (own[r, Bond.KN] - own[r, Bond.KS]) * dn * ds + m
        tb = -(rbx * gz - rbz * gx) - m
        work = gx * (b[i, Body.VX] - vbx) + gz * (b[i, Body.VZ] - vbz) + ta * b[i, Body.OM] + tb * omb
        out = 0.5 * (fn * dn + fs * ds + m * dth) + 0.5 * step_of(a) * work
    return out


@ti.func
def before_correction(fx: ti.template(), a: ti.template()):
    """Every bond's energy before the overlap correction moves the icebergs (``REL`` holds it
    until :func:`after_correction`; the bonds that broke this step were booked already)."""
    lo, hi = rows(a)
    for r in range(lo, hi):
        a.own[r, Bond.CORR] = held_energy(a, r)


@ti.func
def after_correction(fx: ti.template(), a: ti.template()):
    """What the correction put into each bond, ``CORR`` (before minus after)."""
    lo, hi = rows(a)
    for r in range(lo, hi):
        a.own[r, Bond.CORR] -= held_energy(a, r)


@ti.func
def book_correction(fx: ti.template(), a: ti.template()):
    """Each iceberg books its bonds' shares (half each; a wall bond's whole) in
    ``BOND_CORRECTION``: the correction's pushes change the bonds' energy, which the
    correction's own ledger (the icebergs' potential energy) does not see."""
    for i in range(a.b.shape[0]):
        got = 0.0
        for k in ti.static(range(MAX_BONDS)):
            r = ti.cast(a.b[i, Body.BOND_1 + k], ti.i32) - 1
            if r >= 0:
                share = 0.5
                if a.own[r, Bond.B] < 0.0:
                    share = 1.0
                got += share * a.own[r, Bond.CORR]
        a.b[i, Body.BOND_CORRECTION] += got


@ti.func
def correction_stage(fx: ti.template(), a: ti.template()):
    after_correction(fx, a)
    book_correction(fx, a)


@ti.func
def _holds(a: ti.template(), i, j, touching) -> ti.i32:
    """1 if an intact bond whose ``TOUCHING`` is ``touching`` joins icebergs i and j."""
    found = 0
    for k in ti.static(range(MAX_BONDS)):
        r = ti.cast(a.b[i, Body.BOND_1 + k], ti.i32) - 1
        if r >= 0:
            if a.own[r, Bond.INTACT] > 0.5 and (a.own[r, Bond.TOUCHING] > 0.5) == touching:
                if ti.cast(a.own[r, Bond.A], ti.i32) == j or ti.cast(a.own[r, Bond.B], ti.i32) == j:
                    found = 1
    return found


@ti.func
def joined(a: ti.template(), i, j) -> ti.i32:
    """1 if an intact bond joins icebergs i and j over their whole shared face (their contact
    is the bond's)."""
    return _holds(a, i, j, False)


@ti.func
def kept(a: ti.template(), i, j) -> ti.i32:
    """1 if an intact bond holds a ligament between icebergs i and j whose walls beside it
    touch through contacts (a crevassed joint): their impulses act, and the bond, not the
    overlap correction, holds their overlap (the correction's pushes against a stiff bond
    put energy into it: docs/bonds.md, Crevasses)."""
    return _holds(a, i, j, True)


@ti.func
def joined_wall(a: ti.template(), i) -> ti.i32:
    """1 if an intact bond joins iceberg i to the wall."""
    found = 0
    for k in ti.static(range(MAX_BONDS)):
        r = ti.cast(a.b[i, Body.BOND_1 + k], ti.i32) - 1
        if r >= 0:
            if a.own[r, Bond.INTACT] > 0.5 and a.own[r, Bond.B] < 0.0:
                found = 1
    return found


# at the step's start, before the forces: every bond's forces, and its breaking; after the
# drift and its sub-steps, and around the overlap correction (with contacts): what its pushes put into the bonds
STAGES = (
    ("start", Stage("bonds", update_all, (Part(update_all),))),
    ("substeps", Stage("bonds_before_correction", before_correction, (Part(before_correction),), needs=contacts)),
    (
        "correction",
        Stage("bonds_correction", correction_stage, (Part(after_correction), Part(book_correction)), needs=contacts),
    ),
)

__all__ = [
    "force",
    "after_kick",
    "damp",
    "pre_drift",
    "post_drift",
    "substep_update",
    "substep_damp",
    "joined",
    "joined_wall",
    "kept",
    "STAGES",
    "DRIFT_SUM",
    "update",
]

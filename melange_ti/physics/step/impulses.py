"""The contact law and the impulse pass (docs/model.md, contact impulses).

Per contact with point p, unit normal n (from body j to body i) and arms r_k = p - x_k:
``J = -(1 + e) (v_rel . n) / K`` with ``K = 1/m_i + 1/m_j + (r_i x n)^2/I_i + (r_j x n)^2/I_j``,
applied only when the pair approaches and would touch within the step (speculative
contacts); each impulse dissipates exactly ``0.5 (1 - e^2) (v_rel . n)^2 / K``
(``Acc.COLLISION``). A named effect with an ``impulse`` term replaces that impulse (friction:
one impulse with a tangential part, :func:`..effects.terms.friction.impulse`) and books ledgers of
its own; every ledger of the law goes through one list (:func:`..data.schema.law_ledgers`) in
every form. The wall is a partner of infinite mass (j < 0).

The pass is sequential in a fixed order: body i ascending, its wall contact first, then its
partners j > i ascending; repeated ``contact_passes`` times (Gauss-Seidel). Then the
``check`` stage: while some contact would still close by more than ``DEEP_FRACTION`` of a
disc radius this step, the pass runs again, and if an impulse made a body faster than the
reach it was searched with (a struck iceberg in a packed row), detection runs again first
(at most ``MAX_DETECT`` rounds, :mod:`..stages`), so chains cannot tunnel.
"""

import taichi as ti

from ..data.schema import Acc, Body, BodyInt, Config, Contact, Counter, Param, law_ledgers
from ..effects import IMPULSE_LAW
from ..effects.terms import friction
from .broad import outran
from .pairs import normal_speed, pair_mass, relative_normal

# the effects whose ``impulse`` term replaces the contact law's, by name (their modules stand on
# .pairs, so they are linked here, above it, not in .terms)
LAWS = {"friction": friction}
if {e.name for e in IMPULSE_LAW} - LAWS.keys():
    raise ImportError(
        f"effects with an impulse term but no module in {__name__}.LAWS: {sorted({e.name for e in IMPULSE_LAW} - LAWS.keys())}"
    )


def contact_law(fx):
    """The named effect whose ``impulse`` term is the contact law's impulse, or ``None``."""
    return next((e for e in IMPULSE_LAW if e.on(fx)), None)


def law_impulse(fx):
    """The ``@ti.func`` impulse of the named effect that replaces the contact law's."""
    return LAWS[contact_law(fx).name].impulse


DEEP_FRACTION = 0.1  # a contact still closing by more than this many disc radii runs the pass again


@ti.func
def push(a: ti.template(), i, j, jj, dx, dz, m1, i1, c1, m2, i2, c2):
    """Apply the impulse ``jj d`` to body i at the contact and ``-jj d`` to j (none to the wall)."""
    b = ti.static(a.b)
    b[i, Body.VX] += jj * dx / m1
    b[i, Body.VZ] += jj * dz / m1
    b[i, Body.OM] += c1 * jj / i1
    if j >= 0:
        b[j, Body.VX] -= jj * dx / m2
        b[j, Body.VZ] -= jj * dz / m2
        b[j, Body.OM] -= c2 * jj / i2


@ti.func
def resolve(fx: ti.template(), a: ti.template(), i, j, px, pz, nx, nz, gap, slot, defer: ti.template()):
    """Apply the impulse of the contact law to the pair (i, j) (j < 0: the wall) if it approaches.

    Its energy terms and impulse go to the run-wide sums (``acc``) at once, or, with
    ``defer`` (islands solved side by side, :mod:`..forms.islands`), to the contact's ``DEF_*``
    columns at ``[slot, i]``, which :func:`book` adds to ``acc`` afterwards in this pass's
    order, so that the sums are the same bits."""
    b = ti.static(a.b)
    rx1 = px - b[i, Body.X]
    rz1 = pz - b[i, Body.Z]
    rx2 = 0.0
    rz2 = 0.0
    if j >= 0:
        rx2 = px - b[j, Body.X]
        rz2 = pz - b[j, Body.Z]
    vn = normal_speed(a, i, j, rx1, rz1, rx2, rz2, nx, nz)
    cap, room = crush_room(fx, a, i, slot)
    hit = vn < 0 and gap + a.par[Param.DT] * vn < 0
    if ti.static(fx.crushing):
        hit = hit and room > 0  # a contact at its cap crushes: no impulse more this step
    if hit:
        e = a.par[Param.RESTITUTION]
        kk, m1, i1, a1, m2, i2, a2 = pair_mass(fx, a, i, j, rx1, rz1, rx2, rz2, nx, nz)
        # the step's energy is the kinetic energy at the mid-kick velocities, half a kick
        # before the ones the impulse acts on: book the difference (docs/model.md)
        kick_vn = relative_normal(a, i, j, Body.KICK_VX, Body.KICK_VZ, Body.KICK_OM, rx1, rz1, rx2, rz2, nx, nz)
        jn = 0.0
        terms = ti.Vector(ti.static([0.0] * len(law_ledgers(fx))))
        if ti.static(contact_law(fx) in IMPULSE_LAW):
            impulse = ti.static(law_impulse(fx))
            jn, terms = impulse(fx, a, i, j, rx1, rz1, rx2, rz2, nx, nz, vn, e, kk, m1, i1, a1, m2, i2, a2, kick_vn, room)
        else:
            jn = -(1.0 + e) * vn / kk
            dissipated = 0.5 * (1.0 - e * e) * vn * vn / kk
            if ti.static(fx.crushing):
                if jn > room:  # the ice crushes: the contact passes what it can carry this step
                    jn = room
                    dissipated = -jn * (vn + 0.5 * jn * kk)
            push(a, i, j, jn, nx, nz, m1, i1, a1, m2, i2, a2)
            terms = ti.Vector([dissipated, 0.5 * jn * kick_vn])
        if ti.static(fx.crushing):
            spend(a, i, slot, jn, cap, room)
        if ti.static(defer):
            a.cd[slot, i, Contact.DEF_IMPULSE] = jn
            for q in ti.static(range(len(law_ledgers(fx)))):
                a.cd[slot, i, ti.static(law_ledgers(fx)[q][1])] = terms[q]
        else:
            if j < 0:
                a.acc[Acc.WALL_IMPULSE] += jn
            a.acc[Acc.IMPULSE] += jn
            for q in ti.static(range(len(law_ledgers(fx)))):
                a.acc[ti.static(law_ledgers(fx)[q][0])] += terms[q]
            a.cnt[Counter.IMPULSES] += 1  # deferred: counted by book (no atomics in the islands' loop)


@ti.func
def crush_room(fx: ti.template(), a: ti.template(), i, slot):
    """With crushing (effect ``crushing``): ``(cap, room)``, the normal impulse the contact
    may pass in a step, ``F_c dt`` with ``F_c = p_c h_c``, and what is left of it this step
    (``Contact.SPENT``, zeroed at detection); without, ``(0, 0)``, unused."""
    cap = 0.0
    room = 0.0
    if ti.static(fx.crushing):
        cap = a.par[Param.CRUSH_PRESSURE] * a.par[Param.CRUSH_HEIGHT] * a.par[Param.DT]
        room = cap - a.cd[slot, i, Contact.SPENT]
    return cap, room


@ti.func
def spend(a: ti.template(), i, slot, jn, cap, room):
    """Add the impulse ``jn`` to what the contact has passed this step; one that took all the
    room leaves the contact exactly at its cap (so :func:`deep_approach` lets it crush)."""
    if jn >= room:
        a.cd[slot, i, Contact.SPENT] = cap
    else:
        a.cd[slot, i, Contact.SPENT] += jn


@ti.func
def contact_range(fx: ti.template(), a: ti.template(), i):
    """Body i's contacts as a range of slots in the pass's order: ``-1`` its wall contact
    (if it has one), then its partners j > i ascending (:func:`contact`)."""
    first = 0
    if ti.static(fx.wall):
        first = -a.bi[i, BodyInt.WALL_ON]
    last = 0
    if ti.static(fx.collisions):
        last = a.bi[i, BodyInt.NCONTACT]
    return first, last


@ti.func
def contact(fx: ti.template(), a: ti.template(), i, s):
    """Contact ``s`` of body i (:func:`contact_range`): ``(j, slot, px, pz, nx, nz, gap)``,
    j = -1 and slot ``Config.SLOTS`` for the wall.

    Passes over a body's contacts walk this one range with one call site of their contact
    law, not a wall call then a partner loop: with two call sites, Vulkan on lavapipe
    skipped the partners' impulses in the island-parallel pass (docs/devices.md). The
    arithmetic is the same either way."""
    b = ti.static(a.b)
    cd = ti.static(a.cd)
    j = -1
    slot = ti.cast(a.cfg[Config.SLOTS], ti.i32)
    px, pz, nx, nz, gap = 0.0, 0.0, 1.0, 0.0, 0.0
    if ti.static(fx.wall):
        px = a.par[Param.WALL_X]
        pz = b[i, Body.WALL_PZ]
        gap = b[i, Body.WALL_GAP]
    if s >= 0:
        j = a.cp[s, i]
        slot = s
        px = cd[s, i, Contact.PX]
        pz = cd[s, i, Contact.PZ]
        nx = cd[s, i, Contact.NX]
        nz = cd[s, i, Contact.NZ]
        gap = cd[s, i, Contact.GAP]
    return j, slot, px, pz, nx, nz, gap


@ti.func
def in_pass(fx: ti.template(), a: ti.template(), i, slot):
    """Whether a pass over body i's contacts takes the contact at ``slot``: every one, or with
    coloured passes (``fx.coloured``, :mod:`..forms.colours`) those of the colour under way,
    ``Counter.COLOUR``."""
    take = 1
    if ti.static(fx.coloured):
        take = ti.cast(ti.cast(a.cd[slot, i, Contact.COLOUR], ti.i32) == a.cnt[Counter.COLOUR], ti.i32)
    return take


@ti.func
def body_contacts(fx: ti.template(), a: ti.template(), i, defer: ti.template()):
    """Body i's contacts in the pass's order (:func:`contact_range`; coloured: those of the
    colour under way, :func:`in_pass`); deferred terms of the wall contact go to slot
    ``Config.SLOTS``."""
    first, last = contact_range(fx, a, i)
    for s in range(first, last):
        j, slot, px, pz, nx, nz, gap = contact(fx, a, i, s)
        if in_pass(fx, a, i, slot):
            resolve(fx, a, i, j, px, pz, nx, nz, gap, slot, defer)


@ti.func
def impulse_pass(fx: ti.template(), a: ti.template()):
    n = ti.cast(a.cfg[Config.N], ti.i32)
    for _ in range(ti.cast(a.cfg[Config.PASSES], ti.i32)):
        for i in range(n):
            body_contacts(fx, a, i, False)


@ti.func
def book_one(fx: ti.template(), a: ti.template(), s, i, wall: ti.template()):
    cd = ti.static(a.cd)
    jn = cd[s, i, Contact.DEF_IMPULSE]
    if jn > 0:  # an impulse was applied (J > 0 whenever one is)
        if ti.static(wall):
            a.acc[Acc.WALL_IMPULSE] += jn
        a.acc[Acc.IMPULSE] += jn
        for q in ti.static(range(len(law_ledgers(fx)))):
            a.acc[ti.static(law_ledgers(fx)[q][0])] += cd[s, i, ti.static(law_ledgers(fx)[q][1])]
        a.cnt[Counter.IMPULSES] += 1
        cd[s, i, Contact.DEF_IMPULSE] = 0.0


@ti.func
def book(fx: ti.template(), a: ti.template()):
    """Add the deferred terms of one island-parallel pass to ``acc`` in the sequential
    pass's order (body ascending: wall, then partners), clearing them: the same bits as
    :func:`impulse_pass`'s own sums."""
    book_bodies(fx, a, 0, ti.cast(a.cfg[Config.N], ti.i32))


@ti.func
def book_bodies(fx: ti.template(), a: ti.template(), start, end):
    """:func:`book` for the bodies ``start <= i < end``, in order."""
    for i in range(start, end):
        if ti.static(fx.wall):
            if a.bi[i, BodyInt.WALL_ON]:
                book_one(fx, a, ti.cast(a.cfg[Config.SLOTS], ti.i32), i, True)
        if ti.static(fx.collisions):
            for s in range(a.bi[i, BodyInt.NCONTACT]):
                book_one(fx, a, s, i, False)


@ti.func
def deep_approach(fx: ti.template(), a: ti.template(), i, j, slot, px, pz, nx, nz, gap):
    """1 if the contact still approaches so fast that it would overlap by more than
    DEEP_FRACTION of a disc radius by the end of the step, and may still pass an impulse
    (with crushing, a contact at its cap crushes instead)."""
    b = ti.static(a.b)
    rx2 = 0.0
    rz2 = 0.0
    r = b[i, Body.RADIUS]
    if j >= 0:
        rx2 = px - b[j, Body.X]
        rz2 = pz - b[j, Body.Z]
        r = ti.min(r, b[j, Body.RADIUS])
    vn = normal_speed(a, i, j, px - b[i, Body.X], pz - b[i, Body.Z], rx2, rz2, nx, nz)
    deep = ti.cast(vn < 0 and gap + a.par[Param.DT] * vn < -DEEP_FRACTION * r, ti.i32)
    if ti.static(fx.crushing):
        _cap, room = crush_room(fx, a, i, slot)
        if room <= 0:
            deep = 0  # at its cap: the contact crushes, another pass would not push it
    return deep


@ti.func
def deep_contacts(fx: ti.template(), a: ti.template(), i):
    """How many of body i's contacts (wall, partners j > i) still approach deeply."""
    count = 0
    first, last = contact_range(fx, a, i)
    for s in range(first, last):
        j, slot, px, pz, nx, nz, gap = contact(fx, a, i, s)
        count += deep_approach(fx, a, i, j, slot, px, pz, nx, nz, gap)
    return count


@ti.func
def check(fx: ti.template(), a: ti.template()):
    """``Counter.AGAIN``: 2 if some body outran its reach (detect again), else 1 if some
    contact still approaches deeply (another impulse pass), else 0."""
    a.cnt[Counter.AGAIN] = 0
    for i in range(a.b.shape[0]):
        if outran(a, i):
            ti.atomic_max(a.cnt[Counter.AGAIN], 2)
        elif deep_contacts(fx, a, i) > 0:
            ti.atomic_max(a.cnt[Counter.AGAIN], 1)

"""Coloured contact passes (``contacts.order = "coloured"``; docs/performance.md, "Coloured passes").

The sequential impulse pass and the overlap correction visit the contacts body by body,
one after another: Gauss-Seidel in index order. Their parallel forms (islands, groups)
keep that order, so a jammed melange, one island of every iceberg, is solved on one
thread. Exact pair conservation does not need one thread: it needs each impulse applied to
its two bodies together. Here each detection's contacts (the wall's included) are
coloured so that no two contacts of a colour share an iceberg; the passes then run colour
by colour, a colour's contacts side by side, each impulse or push applied to both bodies
by the thread that computes it (Box2D v3 solves its constraint graph's colours so). It is
another Gauss-Seidel order of the same contact law: restitution, friction,
``contact_passes`` and the correction keep their meaning.

**The colouring** (Jones and Plassmann 1993), in parallel and deterministic: each contact
has a fixed priority, a bijective integer hash of its number ``i (SLOTS + 1) + slot`` (the
wall's slot is ``SLOTS``) in the high bits and the number itself in the low bits, so no
two contacts tie and neighbours along a row are in no particular order. Each round, every
body records the highest priority among its uncoloured contacts (``BodyInt.COLOUR_TOP``);
a contact that holds the highest priority at both its bodies takes the lowest colour that
neither body's coloured contacts have (``BodyInt.COLOUR_USED``, a bit mask). Two contacts
coloured in one round share no body, so what a round decides depends only on the rounds
before it: the colours are the same on any number of threads and on any device, and the
serial form (every loop serial) gives them too. Rounds repeat while a contact is left
(``Counter.CHANGED``); expected rounds grow as the logarithm of the contacts. A device
runs the rounds over the flattened contact slots (:func:`colour_round_flat`: one loop
iteration per slot, no loop over a body's contacts), the CPU per body; the colours are the
same (tested with ``Model(device_parts=True)`` on the CPU).

Colours ``0 .. MAX_COLOURS - 1`` are the bits of an i32 mask. A contact whose bodies have
used them all (a body with more than about 15 contacts) takes ``OVERFLOW``, whose contacts
are solved on one thread in body order after the others (as Box2D's overflow
constraints): always correct, parallel only below the limit.

**The passes.** Each colour is one launch over the bodies, skipping those none of whose own
contacts (``BodyInt.COLOUR_OWN``) has it; the colour comes from ``Counter.COLOUR``, which
the launch's last task advances. The impulses' energy terms are deferred per contact and
booked in body order afterwards (:func:`..step.impulses.book`; on a device the block sums),
the correction's per body, as in the islands' form: the run-wide sums do not depend on the
order the colours ran in. The correction's sweeps (at most ``MAX_CORRECT``) run every
colour in turn and stop after a sweep that pushes nothing (``Counter.CHANGED``).
"""

import taichi as ti

from ..data.schema import BodyInt, Config, Contact, Counter
from ..step import correction
from ..step.correction import MAX_CORRECT, sweep_body
from ..step.impulses import body_contacts, book, contact, contact_range

MAX_COLOURS = 31  # colours with a bit in an i32 mask
OVERFLOW = MAX_COLOURS  # the colour of contacts left over: solved on one thread
LOWEST = -2147483647  # below every priority


def id_bits(n: int, slots: int) -> int:
    """Bits of the largest contact number of n bodies with ``slots`` slots each (``Config.ID_BITS``)."""
    return max(1, (n * (slots + 1) - 1).bit_length())


@ti.func
def priority(a: ti.template(), i, slot):
    """The contact ``(i, slot)``'s priority: distinct for every contact, hashed so that
    neighbours' priorities are in no order (``slot`` ``Config.SLOTS``: the wall's)."""
    number = i * (ti.cast(a.cfg[Config.SLOTS], ti.i32) + 1) + slot
    bits = ti.cast(a.cfg[Config.ID_BITS], ti.i32)
    h = ti.cast(number, ti.u32)
    mul = ti.cast(0x45D9F3B, ti.u32)
    h = ((h >> 16) ^ h) * mul
    h = ((h >> 16) ^ h) * mul
    h = (h >> 16) ^ h
    p = number
    if bits < 31:
        p = ti.cast(((h >> (bits + 1)) << bits), ti.i32) | number
    return p


@ti.func
def colour_of(a: ti.template(), i, slot):
    return ti.cast(a.cd[slot, i, Contact.COLOUR], ti.i32)


@ti.func
def lowest_free(mask):
    """The lowest colour whose bit ``mask`` lacks (``OVERFLOW`` if it has them all)."""
    k = 0
    while k < MAX_COLOURS and (mask >> k) & 1:
        k += 1
    return k


# ---------------------------------------------------------------- the colouring
@ti.func
def colour_start(fx: ti.template(), a: ti.template()):
    """No contact coloured, no colour used; the passes will start at colour 0."""
    a.cnt[Counter.COLOURS] = 0
    a.cnt[Counter.COLOUR] = 0
    a.cnt[Counter.SLOTS_USED] = 0
    for i in range(a.b.shape[0]):
        if ti.static(fx.collisions):
            ti.atomic_max(a.cnt[Counter.SLOTS_USED], a.bi[i, BodyInt.NCONTACT])
        a.bi[i, BodyInt.COLOUR_USED] = 0
        a.bi[i, BodyInt.COLOUR_OWN] = 0
        first, last = contact_range(fx, a, i)
        for s in range(first, last):
            _j, slot, _px, _pz, _nx, _nz, _gap = contact(fx, a, i, s)
            a.cd[slot, i, Contact.COLOUR] = -1.0


@ti.func
def _take_colour(a: ti.template(), i, slot, j):
    """Colour the contact ``(i, slot)`` with partner j (< 0: the wall) the lowest colour its
    bodies' contacts lack."""
    bi = ti.static(a.bi)
    used = bi[i, BodyInt.COLOUR_USED]
    if j >= 0:
        used |= bi[j, BodyInt.COLOUR_USED]
    k = lowest_free(used)
    a.cd[slot, i, Contact.COLOUR] = k
    ti.atomic_max(a.cnt[Counter.COLOURS], k + 1)
    if k < MAX_COLOURS:
        bit = 1 << k
        bi[i, BodyInt.COLOUR_USED] |= bit
        bi[i, BodyInt.COLOUR_OWN] |= bit
        if j >= 0:
            bi[j, BodyInt.COLOUR_USED] |= bit


@ti.func
def _offer(a: ti.template(), i, slot, j):
    """An uncoloured contact's priority raised into both its bodies' ``COLOUR_TOP``."""
    bi = ti.static(a.bi)
    if colour_of(a, i, slot) < 0:
        p = priority(a, i, slot)
        ti.atomic_max(bi[i, BodyInt.COLOUR_TOP], p)
        if j >= 0:
            ti.atomic_max(bi[j, BodyInt.COLOUR_TOP], p)


@ti.func
def _decide(a: ti.template(), i, slot, j):
    """An uncoloured contact that holds the top priority at both its bodies takes a colour;
    one that does not says a round is still needed (``Counter.CHANGED``)."""
    bi = ti.static(a.bi)
    if colour_of(a, i, slot) < 0:
        p = priority(a, i, slot)
        top = ti.cast(p == bi[i, BodyInt.COLOUR_TOP], ti.i32)
        if j >= 0:
            if p != bi[j, BodyInt.COLOUR_TOP]:
                top = 0
        if top:
            _take_colour(a, i, slot, j)
        else:
            a.cnt[Counter.CHANGED] = 1


@ti.func
def colour_round(fx: ti.template(), a: ti.template()):
    """One round: each body's highest uncoloured priority, then every contact that holds it
    at both its bodies coloured; ``Counter.CHANGED`` 1 while contacts are left."""
    bi = ti.static(a.bi)
    a.cnt[Counter.CHANGED] = 0
    for i in range(a.b.shape[0]):
        bi[i, BodyInt.COLOUR_TOP] = LOWEST
    for i in range(a.b.shape[0]):
        first, last = contact_range(fx, a, i)
        for s in range(first, last):
            j, slot, _px, _pz, _nx, _nz, _gap = contact(fx, a, i, s)
            _offer(a, i, slot, j)
    for i in range(a.b.shape[0]):
        first, last = contact_range(fx, a, i)
        for s in range(first, last):
            j, slot, _px, _pz, _nx, _nz, _gap = contact(fx, a, i, s)
            _decide(a, i, slot, j)


@ti.func
def flat_contact(fx: ti.template(), a: ti.template(), q):
    """Contact number ``q = s N + i`` of the flattened list, ``s`` below the most slots a body
    uses (``Counter.SLOTS_USED``, :func:`colour_start`) a partner's slot and ``s`` equal to it
    the wall's: ``(i, slot, j, there)``, ``there`` 0 where body i has no such contact."""
    n = a.b.shape[0]
    used = ti.cast(a.cnt[Counter.SLOTS_USED], ti.i32)
    slot = q // n
    i = q - slot * n
    j = -1
    there = 0
    if slot == used:
        slot = ti.cast(a.cfg[Config.SLOTS], ti.i32)
        if ti.static(fx.wall):
            there = a.bi[i, BodyInt.WALL_ON]
    else:
        if ti.static(fx.collisions):
            if slot < a.bi[i, BodyInt.NCONTACT]:
                there = 1
                j = a.cp[slot, i]
    return i, slot, j, there


@ti.func
def colour_round_flat(fx: ti.template(), a: ti.template()):
    """:func:`colour_round` over the flattened contacts, one loop iteration per contact slot
    (the device's form: the same colours). On lavapipe the per-body form lost a partner's
    ``atomic_max`` made inside the loop over a body's contacts (docs/devices.md)."""
    bi = ti.static(a.bi)
    a.cnt[Counter.CHANGED] = 0
    total = a.b.shape[0] * (ti.cast(a.cnt[Counter.SLOTS_USED], ti.i32) + 1)
    for i in range(a.b.shape[0]):
        bi[i, BodyInt.COLOUR_TOP] = LOWEST
    for q in range(total):
        i, slot, j, there = flat_contact(fx, a, q)
        if there:
            _offer(a, i, slot, j)
    for q in range(total):
        i, slot, j, there = flat_contact(fx, a, q)
        if there:
            _decide(a, i, slot, j)


@ti.func
def colour_serial(fx: ti.template(), a: ti.template()):
    """The colouring with serial loops (the serial form): the same rounds, the same colours."""
    colour_start(fx, a)
    for _round in range(a.b.shape[0] * (ti.cast(a.cfg[Config.SLOTS], ti.i32) + 1)):
        colour_round(fx, a)
        if a.cnt[Counter.CHANGED] == 0:
            break


# ---------------------------------------------------------------- the impulse pass
# A coloured model's passes over a body's contacts take only the colour under way,
# ``Counter.COLOUR`` (:func:`..step.impulses.in_pass`): the serial loops set it too.
@ti.func
def next_colour(a: ti.template(), k):
    """Advance ``Counter.COLOUR`` past ``k`` (back to 0 after the last)."""
    nxt = k + 1
    if nxt >= a.cnt[Counter.COLOURS]:
        nxt = 0
    a.cnt[Counter.COLOUR] = nxt


@ti.func
def impulse_colour(fx: ti.template(), a: ti.template()):
    """The impulses of colour ``Counter.COLOUR``, its contacts side by side (the overflow
    colour's on one thread, in body order); terms deferred (:func:`..step.impulses.book`)."""
    for i in range(a.b.shape[0]):
        k = ti.cast(a.cnt[Counter.COLOUR], ti.i32)
        if k < MAX_COLOURS and (a.bi[i, BodyInt.COLOUR_OWN] >> k) & 1:
            body_contacts(fx, a, i, True)
    for _ in range(1):
        k = ti.cast(a.cnt[Counter.COLOUR], ti.i32)
        if k == OVERFLOW:
            for i in range(a.b.shape[0]):
                body_contacts(fx, a, i, True)
        next_colour(a, k)


@ti.func
def impulse_colours_serial(fx: ti.template(), a: ti.template()):
    """Every colour in turn with serial loops, the pass ``contact_passes`` times, each pass
    booked (the serial form of the parallel parts, the same bits)."""
    for _pass in range(ti.cast(a.cfg[Config.PASSES], ti.i32)):
        for k in range(ti.cast(a.cnt[Counter.COLOURS], ti.i32)):
            a.cnt[Counter.COLOUR] = k
            for i in range(a.b.shape[0]):
                body_contacts(fx, a, i, True)
        book(fx, a)


# ---------------------------------------------------------------- the overlap correction
@ti.func
def correct_first(fx: ti.template(), a: ti.template()):
    """The sweeps start: sweep 0, colour 0, nothing pushed."""
    a.cnt[Counter.SWEEP] = 0
    a.cnt[Counter.COLOUR] = 0
    a.cnt[Counter.PUSHES] = 0
    a.cnt[Counter.CHANGED] = 1


@ti.func
def correct_colour(fx: ti.template(), a: ti.template()):
    """The pushes of colour ``Counter.COLOUR`` in sweep ``Counter.SWEEP``, side by side (the
    overflow colour's on one thread); after the sweep's last colour, ``Counter.CHANGED``
    says whether it pushed, and the next sweep starts."""
    for i in range(a.b.shape[0]):
        k = ti.cast(a.cnt[Counter.COLOUR], ti.i32)
        if k < MAX_COLOURS and (a.bi[i, BodyInt.COLOUR_OWN] >> k) & 1:
            pushed = sweep_body(fx, a, ti.cast(a.cnt[Counter.SWEEP], ti.i32), i, True)
            if pushed > 0:
                ti.atomic_add(a.cnt[Counter.PUSHES], pushed)
    for _ in range(1):
        k = ti.cast(a.cnt[Counter.COLOUR], ti.i32)
        sweep = ti.cast(a.cnt[Counter.SWEEP], ti.i32)
        if k == OVERFLOW:
            for i in range(a.b.shape[0]):
                a.cnt[Counter.PUSHES] += sweep_body(fx, a, sweep, i, True)
        next_colour(a, k)
        if a.cnt[Counter.COLOUR] == 0:  # the sweep is done
            a.cnt[Counter.CHANGED] = ti.cast(a.cnt[Counter.PUSHES] > 0, ti.i64)
            a.cnt[Counter.PUSHES] = 0
            a.cnt[Counter.SWEEP] = sweep + 1


@ti.func
def sweeps_serial(fx: ti.template(), a: ti.template()):
    """The sweeps colour by colour with serial loops (the serial form, the same bits)."""
    for sweep in range(MAX_CORRECT):
        pushed = 0
        for k in range(ti.cast(a.cnt[Counter.COLOURS], ti.i32)):
            a.cnt[Counter.COLOUR] = k
            for i in range(a.b.shape[0]):
                pushed += sweep_body(fx, a, sweep, i, True)
        if pushed == 0:
            break


@ti.func
def correction_serial(fx: ti.template(), a: ti.template()):
    """The coloured correction with serial loops: :func:`..step.correction.prepare_all`
    (eager), the sweeps, each moved body's change of potential energy, booked in body order."""
    correction.prepare_all(fx, a)
    sweeps_serial(fx, a)
    correction.energy_all(fx, a)
    correction.book(fx, a)

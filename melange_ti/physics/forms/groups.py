"""Groups: the sequential passes of the parallel form on every CPU thread (docs/performance.md).

The impulse pass and the correction's sweeps visit the bodies in ascending order, and a
contact joins body i to partners j > i. A body index ``s`` where no contact crosses (no
contact ``(i, j)`` with ``i < s <= j``) splits the bodies into two ranges that share no
contact: solving each range in body order gives every body the bits the one sequential pass
gives it. :func:`split` cuts the bodies at such points into ``Config.GROUPS`` contiguous
groups (one per thread), each at the first uncrossed index at or after its share
``g N / G``; where none is found within half a share after it, that group and the later
ones stay empty (the passes then run as before, on fewer threads), so that a shelf joined
into one island is not walked to its end at every detection.

The first group adds its impulses' energy terms to the run-wide sums as it goes; the later
groups keep them per contact (``Contact.DEF_*``) and :func:`book_later` adds them
afterwards in body order, so the sums are the same bits too. The correction's energy is
already summed in body order (:func:`..step.correction.book`).

Group ``g``'s bodies are ``[ISLAND_START[g], ISLAND_START[g + 1])`` (the islands' columns,
unused when islands are off).

Cheaper than islands on a few threads: finding the cuts walks the bodies once up to the
last cut, and the booking visits only the later groups' contacts. Used only in the CPU's
parallel form without islands (a device runs islands: its parts avoid the two call sites of
the contact law that :func:`impulse_groups` has, see :func:`..step.impulses.contact`).
"""

import taichi as ti

from ..data.schema import BodyInt, Config
from ..step.correction import MAX_CORRECT, sweep_body
from ..step.impulses import body_contacts, book_bodies

# Taichi's CPU range-for gives a loop of a few items to one thread: each group's work sits at
# a multiple of STRIDE iterations of a longer loop, so that the groups land on different
# threads (measured: 2 groups of equal work take 1.0x the time of one at STRIDE 512, 2.0x at 64)
STRIDE = 512


@ti.func
def last_partner(a: ti.template(), i):
    """The highest body body i shares a contact with (i itself if none)."""
    hi = i
    k = a.bi[i, BodyInt.NCONTACT]
    if k > 0:
        hi = a.cp[k - 1, i]  # partners are sorted ascending
    return hi


@ti.func
def split(fx: ti.template(), a: ti.template()):
    """The groups' bounds after a detection (one thread, up to the last cut)."""
    bi = ti.static(a.bi)
    n = ti.cast(a.cfg[Config.N], ti.i32)
    groups = ti.cast(a.cfg[Config.GROUPS], ti.i32)
    bi[0, BodyInt.ISLAND_START] = 0
    g = 1
    reach = -1  # the highest partner of the bodies below i
    i = 0
    while i < n and g < groups:
        share = (g * n) // groups
        if i >= share and reach < i:
            bi[g, BodyInt.ISLAND_START] = i
            g += 1
        elif i >= share + n // (2 * groups):
            break  # no cut near this share (one island spans it): the later groups stay empty
        reach = ti.max(reach, last_partner(a, i))
        i += 1
    while g <= groups:
        bi[g, BodyInt.ISLAND_START] = n
        g += 1


@ti.func
def impulse_groups(fx: ti.template(), a: ti.template()):
    """One impulse pass, the groups side by side; the later groups' energy terms deferred."""
    for q in range(ti.cast(a.cfg[Config.GROUPS], ti.i32) * STRIDE):
        if q % STRIDE == 0:
            g = q // STRIDE
            start, end = a.bi[g, BodyInt.ISLAND_START], a.bi[g + 1, BodyInt.ISLAND_START]
            if g == 0:
                for i in range(start, end):
                    body_contacts(fx, a, i, False)
            else:
                for i in range(start, end):
                    body_contacts(fx, a, i, True)


@ti.func
def book_later(fx: ti.template(), a: ti.template()):
    """The later groups' deferred terms added to the run-wide sums in body order (one
    thread): the bits of the sequential pass's own sums (:func:`..step.impulses.book`)."""
    book_bodies(fx, a, a.bi[1, BodyInt.ISLAND_START], ti.cast(a.cfg[Config.N], ti.i32))


@ti.func
def correct_groups(fx: ti.template(), a: ti.template()):
    """The correction's sweeps, the groups side by side, each until it pushes nothing (as
    :func:`.islands.correct_islands`: a sweep of the sequential pass visits nothing in a group
    that pushed nothing in the last)."""
    for q in range(ti.cast(a.cfg[Config.GROUPS], ti.i32) * STRIDE):
        if q % STRIDE == 0:
            g = q // STRIDE
            start, end = a.bi[g, BodyInt.ISLAND_START], a.bi[g + 1, BodyInt.ISLAND_START]
            for sweep in range(MAX_CORRECT):
                pushed = 0
                for i in range(start, end):
                    pushed += sweep_body(fx, a, sweep, i, True)
                if pushed == 0:
                    break

"""Islands: the impulse pass and the overlap correction solved per island, side by side
(the parallel form; docs/performance.md, "Islands").

An island is a connected group of icebergs linked by this step's contacts (the wall is
immovable and links nothing). Bodies of different islands share no contact, so within a
pass an island's velocities and positions depend on its own contacts only: solving each
island in the sequential pass's order (body ascending; its wall contact, then its partners
j > i ascending) gives every body the bits the sequential pass gives it, on any number of
threads. What crosses islands are the run-wide sums: the impulses' energy terms are kept
per contact (``Contact.DEF_*``) and added afterwards in the sequential order
(:func:`..step.impulses.book`); the corrections' energy is computed per body and summed in body
order; the impulse count is an integer.

:func:`label` (sequential, after each detection) finds the islands by union-find, each
rooted at its lowest body, numbers them by root and lists their bodies, ascending within
each (``BodyInt.ISLAND_ORDER`` from ``ISLAND_START[k]``).
"""

import taichi as ti

from ..data.schema import BodyInt, Config, Counter
from ..step.correction import MAX_CORRECT, sweep_body
from ..step.impulses import body_contacts


@ti.func
def find(a: ti.template(), i):
    """Root of body i's island (path halving)."""
    bi = ti.static(a.bi)
    r = i
    while bi[r, BodyInt.ISLAND] != r:
        up = bi[bi[r, BodyInt.ISLAND], BodyInt.ISLAND]
        bi[r, BodyInt.ISLAND] = up
        r = up
    return r


@ti.func
def label(fx: ti.template(), a: ti.template()):
    """Islands of the contacts just detected (sequential)."""
    bi = ti.static(a.bi)
    n = ti.cast(a.cfg[Config.N], ti.i32)
    for i in range(n):
        bi[i, BodyInt.ISLAND] = i
    if ti.static(fx.collisions):
        for i in range(n):
            for s in range(bi[i, BodyInt.NCONTACT]):
                ri = find(a, i)
                rj = find(a, a.cp[s, i])
                if ri != rj:
                    bi[ti.max(ri, rj), BodyInt.ISLAND] = ti.min(ri, rj)
    # number the islands by root (a root is its island's lowest body) and count their bodies
    count = 0
    for i in range(n):
        r = find(a, i)
        bi[i, BodyInt.ISLAND] = r
        if r == i:
            bi[i, BodyInt.ISLAND_NUM] = count
            bi[count, BodyInt.ISLAND_START] = 0
            count += 1
        bi[bi[r, BodyInt.ISLAND_NUM], BodyInt.ISLAND_START] += 1
    total = 0
    for k in range(count):
        total += bi[k, BodyInt.ISLAND_START]
        bi[k, BodyInt.ISLAND_START] = total  # the island's end for now
    # fill from the ends, bodies descending: each island's bodies end up ascending and
    # ISLAND_START[k] at their start
    for q in range(n):
        i = n - 1 - q
        k = bi[bi[i, BodyInt.ISLAND], BodyInt.ISLAND_NUM]
        bi[k, BodyInt.ISLAND_START] -= 1
        bi[bi[k, BodyInt.ISLAND_START], BodyInt.ISLAND_ORDER] = i
    a.cnt[Counter.ISLANDS] = count


@ti.func
def span(a: ti.template(), k):
    """(start, end) of island k's bodies in ``ISLAND_ORDER``."""
    count = ti.cast(a.cnt[Counter.ISLANDS], ti.i32)
    end = ti.cast(a.cfg[Config.N], ti.i32)
    if k + 1 < count:
        end = a.bi[k + 1, BodyInt.ISLAND_START]
    return a.bi[k, BodyInt.ISLAND_START], end


@ti.func
def impulse_islands(fx: ti.template(), a: ti.template()):
    """One impulse pass, islands in parallel; energy terms deferred (:func:`..step.impulses.book`)."""
    for k in range(ti.cast(a.cnt[Counter.ISLANDS], ti.i32)):
        start, end = span(a, k)
        for p in range(start, end):
            body_contacts(fx, a, a.bi[p, BodyInt.ISLAND_ORDER], True)


@ti.func
def correct_islands(fx: ti.template(), a: ti.template()):
    """The correction's sweeps, islands in parallel, each until it pushes nothing (a sweep
    of the sequential pass visits nothing in an island that pushed nothing in the last)."""
    for k in range(ti.cast(a.cnt[Counter.ISLANDS], ti.i32)):
        start, end = span(a, k)
        for sweep in range(MAX_CORRECT):
            pushed = 0
            for p in range(start, end):
                pushed += sweep_body(fx, a, sweep, a.bi[p, BodyInt.ISLAND_ORDER], True)
            if pushed == 0:
                break

"""Parallel forms, for a device, of the parts the CPU runs on one thread.

On the CPU the parallel form keeps a few parts sequential (``Part(sequential=True)``): the
broad phase's scan of the cell counts, finding the islands, and adding the energy terms to
the run-wide sums in order. A device would run each of them on a single one of its
threads, so a device model (``Model(device_parts=True)``, the default off the CPU) runs
these instead. What is left on one thread is a walk over one value per block of
:data:`BLOCK` bodies or cells (400 values at N = 100,000).

- **Scans** (the cell starts, the island numbers and starts) are blocked: each block sums
  its counts, one thread scans the block sums, each block then scans its own part. Integer
  results: the same as the sequential scans, whatever the thread count.
- **Islands**: labels by parallel min-label propagation with pointer jumping (a body's
  label is always a body of its island, and settles at the island's lowest body: the
  sequential union-find's root), repeated while a label changes (``Counter.CHANGED``; the
  model reads it after each round). The roots are numbered in ascending order, as
  :func:`.islands.label` numbers them, and each island gets the span of bodies from its
  root to its highest body (``ISLAND_START``, ``ISLAND_END``). The island-parallel passes
  walk that span and skip the bodies of other islands: each island's bodies in ascending
  order, as the CPU's passes take them, with no order to build and sort (a sort of an
  island's bodies on one thread of a device is what this replaces).
- **Sums** of the energy terms are pairwise in a fixed shape: each block adds its own terms
  in the sequential order, one thread adds the block sums in block order. The result does
  not depend on the thread count, but it is not the bits of the CPU's one running sum
  (within a few ulps of the total; docs/devices.md).

Partial results live in ``red`` (``(blocks, RED_WIDTH)``, f64; integers are exact there).
"""

import taichi as ti

from ..data.schema import MAX_LAW_LEDGERS, Acc, Body, BodyInt, Cell, Config, Contact, Counter, law_ledgers
from ..step.correction import MAX_CORRECT, sweep_body
from ..step.impulses import body_contacts, contact_range

BLOCK_BITS = 8
BLOCK = 1 << BLOCK_BITS
RED_FIXED = 3  # partial sums per block: the wall's impulses, all impulses, their count; then
RED_WIDTH = RED_FIXED + MAX_LAW_LEDGERS  # the contact law's ledgers (schema.law_ledgers)


def red_rows(n: int, ncells: int) -> int:
    """Rows of ``red`` a model of n bodies and ncells cells needs."""
    return ((max(n, ncells + 1) + BLOCK - 1) >> BLOCK_BITS) + 1


@ti.func
def zero64():
    """0 in f64: the sums are taken in f64 whatever the precision, as ``acc`` is."""
    return ti.cast(0.0, ti.f64)


@ti.func
def blocks(count):
    return (count + BLOCK - 1) >> BLOCK_BITS


@ti.func
def scan_red(a: ti.template(), count):
    """Exclusive scan of ``red[:, 0]`` over the blocks of ``count`` items (one thread)."""
    total = ti.cast(0.0, ti.f64)
    for blk in range(blocks(count)):
        s = a.red[blk, 0]
        a.red[blk, 0] = total
        total += s


# ---------------------------------------------------------------- the broad phase's scan
@ti.func
def block_sums(a: ti.template(), table: ti.template(), col: ti.template(), count):
    """``red[blk, 0]``: the sum of ``table[:, col]`` over each block of ``count`` rows."""
    for blk in range(blocks(count)):
        s = 0
        for r in range(blk * BLOCK, ti.min(count, (blk + 1) * BLOCK)):
            s += table[r, col]
        a.red[blk, 0] = ti.cast(s, ti.f64)


@ti.func
def cell_sums(fx: ti.template(), a: ti.template()):
    block_sums(a, a.cells, Cell.COUNT, ti.cast(a.cfg[Config.NCELLS], ti.i32))


@ti.func
def cell_scan_blocks(fx: ti.template(), a: ti.template()):
    scan_red(a, ti.cast(a.cfg[Config.NCELLS], ti.i32))


@ti.func
def cell_starts(fx: ti.template(), a: ti.template()):
    """Each cell's START and FILL, its COUNT cleared (:func:`..step.broad.scan_cells`, blocked)."""
    cells = ti.static(a.cells)
    ncells = ti.cast(a.cfg[Config.NCELLS], ti.i32)
    for blk in range(blocks(ncells)):
        total = ti.cast(a.red[blk, 0], ti.i32)
        for c in range(blk * BLOCK, ti.min(ncells, (blk + 1) * BLOCK)):
            cells[c, Cell.START] = total
            cells[c, Cell.FILL] = total
            total += cells[c, Cell.COUNT]
            cells[c, Cell.COUNT] = 0
        if blk == blocks(ncells) - 1:
            cells[ncells, Cell.START] = total


# ---------------------------------------------------------------- islands
@ti.func
def label_start(fx: ti.template(), a: ti.template()):
    for i in range(a.bi.shape[0]):
        a.bi[i, BodyInt.ISLAND] = i


@ti.func
def lower(a: ti.template(), i, label):
    """Lower body i's label to ``label``; flags a change. A plain store, no atomic: another
    thread may overwrite it with a higher label of the same island, which the next round
    lowers again (every label written is a body of the island, the root's own is never
    raised, and a round that writes nothing has every contact's labels equal)."""
    if label < a.bi[i, BodyInt.ISLAND]:
        a.bi[i, BodyInt.ISLAND] = label
        a.cnt[Counter.CHANGED] = 1


@ti.func
def label_round(fx: ti.template(), a: ti.template()):
    """One round: each contact lowers both bodies' labels to the lower one, then each body
    jumps to its label's label."""
    bi = ti.static(a.bi)
    a.cnt[Counter.CHANGED] = 0
    if ti.static(fx.collisions):
        for i in range(bi.shape[0]):
            for s in range(bi[i, BodyInt.NCONTACT]):
                j = a.cp[s, i]
                low = ti.min(bi[i, BodyInt.ISLAND], bi[j, BodyInt.ISLAND])
                lower(a, i, low)
                lower(a, j, low)
    for i in range(bi.shape[0]):
        lower(a, i, bi[bi[i, BodyInt.ISLAND], BodyInt.ISLAND])


@ti.func
def root_sums(fx: ti.template(), a: ti.template()):
    n = a.bi.shape[0]
    for blk in range(blocks(n)):
        s = 0
        for i in range(blk * BLOCK, ti.min(n, (blk + 1) * BLOCK)):
            s += ti.cast(a.bi[i, BodyInt.ISLAND] == i, ti.i32)
        a.red[blk, 0] = ti.cast(s, ti.f64)


@ti.func
def root_scan_blocks(fx: ti.template(), a: ti.template()):
    scan_red(a, a.bi.shape[0])


@ti.func
def number_roots(fx: ti.template(), a: ti.template()):
    """Islands numbered by root ascending (``ISLAND_NUM`` at the root), each island's span
    started at its root (``ISLAND_START``, ``ISLAND_END``); ``Counter.ISLANDS``."""
    bi = ti.static(a.bi)
    n = bi.shape[0]
    for blk in range(blocks(n)):
        k = ti.cast(a.red[blk, 0], ti.i32)
        for i in range(blk * BLOCK, ti.min(n, (blk + 1) * BLOCK)):
            if bi[i, BodyInt.ISLAND] == i:
                bi[i, BodyInt.ISLAND_NUM] = k
                bi[k, BodyInt.ISLAND_START] = i
                bi[k, BodyInt.ISLAND_END] = i + 1
                k += 1
        if blk == blocks(n) - 1:
            a.cnt[Counter.ISLANDS] = k


@ti.func
def island_ends(fx: ti.template(), a: ti.template()):
    """Each island's span ends after its highest body."""
    bi = ti.static(a.bi)
    for i in range(bi.shape[0]):
        ti.atomic_max(bi[bi[bi[i, BodyInt.ISLAND], BodyInt.ISLAND_NUM], BodyInt.ISLAND_END], i + 1)


@ti.func
def impulse_spans(fx: ti.template(), a: ti.template()):
    """One impulse pass, islands in parallel (:func:`.islands.impulse_islands`), each
    island's bodies found in its span: ascending, with no order to build."""
    bi = ti.static(a.bi)
    for k in range(ti.cast(a.cnt[Counter.ISLANDS], ti.i32)):
        root = bi[k, BodyInt.ISLAND_START]
        for i in range(root, bi[k, BodyInt.ISLAND_END]):
            if bi[i, BodyInt.ISLAND] == root:
                body_contacts(fx, a, i, True)


@ti.func
def correct_spans(fx: ti.template(), a: ti.template()):
    """The correction's sweeps, islands in parallel (:func:`.islands.correct_islands`),
    each island's bodies found in its span."""
    bi = ti.static(a.bi)
    for k in range(ti.cast(a.cnt[Counter.ISLANDS], ti.i32)):
        root = bi[k, BodyInt.ISLAND_START]
        for sweep in range(MAX_CORRECT):
            pushed = 0
            for i in range(root, bi[k, BodyInt.ISLAND_END]):
                if bi[i, BodyInt.ISLAND] == root:
                    pushed += sweep_body(fx, a, sweep, i, True)
            if pushed == 0:
                break


# ---------------------------------------------------------------- the energy sums
@ti.func
def impulse_sums(fx: ti.template(), a: ti.template()):
    """Per block, the deferred terms of its bodies' impulses in the sequential order
    (:func:`..step.impulses.book`), cleared: the wall's impulses, all impulses, their count and
    the contact law's ledgers (:func:`..data.schema.law_ledgers`), in columns ``RED_FIXED + q``."""
    cd = ti.static(a.cd)
    n = a.bi.shape[0]
    for blk in range(blocks(n)):
        wal, imp = zero64(), zero64()
        led = ti.Vector(ti.static([0.0] * len(law_ledgers(fx))), dt=ti.f64)
        count = 0
        for i in range(blk * BLOCK, ti.min(n, (blk + 1) * BLOCK)):
            first, last = contact_range(fx, a, i)
            for s0 in range(first, last):
                s = s0
                if s0 < 0:
                    s = ti.cast(a.cfg[Config.SLOTS], ti.i32)
                jn = cd[s, i, Contact.DEF_IMPULSE]
                if jn > 0:
                    if s0 < 0:
                        wal += jn
                    imp += jn
                    for q in ti.static(range(len(law_ledgers(fx)))):
                        led[q] += cd[s, i, ti.static(law_ledgers(fx)[q][1])]
                    count += 1
                    cd[s, i, Contact.DEF_IMPULSE] = 0.0
        a.red[blk, 0] = wal
        a.red[blk, 1] = imp
        a.red[blk, 2] = ti.cast(count, ti.f64)
        for q in ti.static(range(len(law_ledgers(fx)))):
            a.red[blk, RED_FIXED + q] = led[q]


@ti.func
def impulse_total(fx: ti.template(), a: ti.template()):
    wal, imp = zero64(), zero64()
    led = ti.Vector(ti.static([0.0] * len(law_ledgers(fx))), dt=ti.f64)
    count = ti.cast(0, ti.i64)
    for blk in range(blocks(a.bi.shape[0])):
        wal += a.red[blk, 0]
        imp += a.red[blk, 1]
        count += ti.cast(a.red[blk, 2], ti.i64)
        for q in ti.static(range(len(law_ledgers(fx)))):
            led[q] += a.red[blk, RED_FIXED + q]
    a.cnt[Counter.IMPULSES] += count
    a.acc[Acc.WALL_IMPULSE] += wal
    a.acc[Acc.IMPULSE] += imp
    for q in ti.static(range(len(law_ledgers(fx)))):
        a.acc[ti.static(law_ledgers(fx)[q][0])] += led[q]


@ti.func
def correction_sums(fx: ti.template(), a: ti.template()):
    """Per block, its moved bodies' changes of potential energy (:func:`..step.correction.book`)."""
    n = a.bi.shape[0]
    for blk in range(blocks(n)):
        du = zero64()
        for i in range(blk * BLOCK, ti.min(n, (blk + 1) * BLOCK)):
            if a.bi[i, BodyInt.PUSHED] >= 0:
                du += a.b[i, Body.POT_START]
        a.red[blk, 0] = du


@ti.func
def correction_total(fx: ti.template(), a: ti.template()):
    du = zero64()
    for blk in range(blocks(a.bi.shape[0])):
        du += a.red[blk, 0]
    a.acc[Acc.CORRECTION] -= du

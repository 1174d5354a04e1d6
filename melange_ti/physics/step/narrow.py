"""Narrow phase: one contact per touching pair of icebergs, from their discs.

Contacts are found in parallel (one body i per thread): body i's contacts with partners
j > i go into its slots sorted by j, so the contact list does not depend on the thread
count. A contact is kept if its gap may close within this step (speculative contacts: no
tunnelling at any speed); the wall's contact is found by :func:`.wall.detect`.

**Candidate lists.** Where icebergs collide (``Config.LISTS``) each body keeps, per partner,
the disc pairs within touching distance plus a skin, and visits only those while the pair
has not moved by more than the skin allows (:func:`narrow`): the same contacts, bit for bit,
for less work. ``nl`` (N, :func:`list_width`, i32) holds body i's lists, one entry e per
partner: the partner (:func:`list_partner`, -1: free), the count of kept runs
(:func:`list_count`, -1: none kept) and the runs' codes (:func:`list_code`): a run is one
disc of i, one face of j and consecutive discs of j on it (the pairs within reach of one
disc of i on a face of j are consecutive), so one code stands for a whole row of pairs, and
a body's partners and counts share its first cache line (sizes and timings:
``docs/performance.md``). ``nr`` holds the
pose each list was made at (:data:`..data.schema.LIST_POSES`); ``BodyInt.NEXT_ENTRY`` is the
entry a new partner takes (round robin).
"""

import taichi as ti

from ..data.schema import Body, BodyInt, Cell, Config, Contact, Counter, ListPose, Param
from ..effects import JOINED, JOINED_WALL
from ..numerics import FAR, TINY
from ..shape.discs import line_window
from ..shape.faces import (
    FACE_BITS,
    box,
    boxes_apart,
    edge_discs,
    edge_line,
    edge_spacing,
    edges,
    face_in_j,
    grown,
    j_face,
    pair_term,
)
from ..shape.hydrostatics import halves
from . import wall
from .broad import cell_size, margin, reach
from .terms import term as term_of

# Candidate lists: partners kept per body, disc pairs kept per partner, and the skin (a
# fraction of the smaller disc radius) added to the touching distance.
ENTRIES = 4
MAX_RUNS = 62  # runs of kept pairs per entry (:func:`pack_pair`): k + 8 for k discs per face, at most this
SKIN = 0.2

# A kept run is one i32 code: i's face (FACE_BITS: 2), i's disc on it (6), j's face (2),
# j's first disc (6), how many consecutive discs of j (7, from bit _LEN_SHIFT); so lists
# are kept only up to MAX_FACE_DISCS discs per face.
DISC_BITS = 6
MAX_FACE_DISCS = 1 << DISC_BITS
_FB_SHIFT = DISC_BITS
_IA_SHIFT = DISC_BITS + FACE_BITS
_FA_SHIFT = 2 * DISC_BITS + FACE_BITS
_LEN_SHIFT = 2 * DISC_BITS + 2 * FACE_BITS


def list_runs(k: int) -> int:
    """Runs kept per entry for ``k`` discs per face: about one per disc of i facing j, and
    room for a corner (measured: a smaller row of ``nl`` is a faster narrow phase at large N)."""
    return min(MAX_RUNS, k + 8)


def list_width(k: int) -> int:
    """A body's row of ``nl`` for ``k`` discs per face."""
    return ENTRIES * (2 + list_runs(k))


@ti.func
def list_partner(e):
    """Position of entry e's partner in a body's row of ``nl``."""
    return e


@ti.func
def list_count(e):
    """Position of entry e's count of kept runs."""
    return ENTRIES + e


@ti.func
def list_code(e, q, runs):
    """Position of entry e's q-th kept run (``runs`` per entry)."""
    return 2 * ENTRIES + e * runs + q


@ti.func
def pack_pair(fa, ia, fb, ib):
    return (fa << _FA_SHIFT) | (ia << _IA_SHIFT) | (fb << _FB_SHIFT) | ib


@ti.func
def unpack_pair(code):
    return (
        (code >> _FA_SHIFT) & ((1 << FACE_BITS) - 1),
        (code >> _IA_SHIFT) & (MAX_FACE_DISCS - 1),
        (code >> _FB_SHIFT) & ((1 << FACE_BITS) - 1),
        code & (MAX_FACE_DISCS - 1),
    )


@ti.func
def add_pair(perp, off, du, dv, d2, au, av, ri, rj, motion, rch, near, standby, gap):
    """A disc pair within touching distance adds its term to the sums of the pairs closing
    within this step (``near``, weighted by ``motion - g``) and of all pairs (``standby``,
    by ``rch - g``), and its gap to the smallest; returns the three."""
    g, term = pair_term(perp, off, du, dv, d2, au, av, ri, rj)
    return add_term(g, term, motion, rch, near, standby, gap)


@ti.func
def add_term(g, term, motion, rch, near, standby, gap):
    """:func:`add_pair` for a pair's gap and term."""
    n, sb = near, standby
    if g < motion:
        n += (motion - g) * term
    sb += (rch - g) * term
    return n, sb, ti.min(gap, g)


@ti.func
def insert_contact(a: ti.template(), i, j, px, pz, nx, nz, gap):
    cnt = a.bi[i, BodyInt.NCONTACT]
    if cnt >= a.cfg[Config.SLOTS]:
        a.cnt[Counter.OVERFLOW] = 1
    else:
        pos = cnt
        while pos > 0 and a.cp[pos - 1, i] > j:
            a.cp[pos, i] = a.cp[pos - 1, i]
            # the geometry only: the deferred terms (DEF_*) are booked and cleared before detection
            for c in ti.static(range(Contact.GAP + 1)):
                a.cd[pos, i, c] = a.cd[pos - 1, i, c]
            pos -= 1
        a.cp[pos, i] = j
        a.cd[pos, i, Contact.PX] = px
        a.cd[pos, i, Contact.PZ] = pz
        a.cd[pos, i, Contact.NX] = nx
        a.cd[pos, i, Contact.NZ] = nz
        a.cd[pos, i, Contact.GAP] = gap
        a.bi[i, BodyInt.NCONTACT] = cnt + 1


@ti.func
def narrow(a: ti.template(), i, j, rch, motion):
    """One contact for the pair (i, j) from its disc pairs.

    Disc pairs closer than ``motion`` (how far the pair can close at its current
    velocities) merge into one contact, weighted by ``motion - gap``. If none is that close
    but some are within ``rch`` (room for velocities an impulse may add), those merge,
    weighted by ``rch - gap``, into a standby contact, so a struck iceberg meets its
    neighbour. Sums are taken in j's body frame, over the disc pairs within touching
    distance in a fixed order (i's face, i's disc, j's face, j's disc).

    Finding those pairs: on each face of i, the discs within reach of j's box; for each, on
    each face of j, the discs within reach of it (an index range from its distance along the
    face). Where lists are on (``a.cfg[Config.LISTS]``: whenever icebergs collide), that
    search also keeps, in i's candidate list for j (``nl``, ``nr``), every disc pair
    within touching distance plus a skin, as runs in the same order, with the pair's
    relative pose. While neither body has moved relative to the other by more than the skin allows,
    later steps visit only the kept pairs. They contain every pair within touching distance
    and the order is the same, so a contact is bit-for-bit the same either way; the list
    only saves the search.
    """
    b = ti.static(a.b)
    k = ti.cast(a.cfg[Config.K], ti.i32)
    runs = ti.min(MAX_RUNS, k + 8)  # list_runs(k)
    ci, si, cj, sj = b[i, Body.COS], b[i, Body.SIN], b[j, Body.COS], b[j, Body.SIN]
    xi, zi, xj, zj = b[i, Body.X], b[i, Body.Z], b[j, Body.X], b[j, Body.Z]
    hwi, hhi = halves(a, i)
    hwj, hhj = halves(a, j)
    bui, bvi = box(a, i, hwi, hhi)
    buj, bvj = box(a, j, hwj, hhj)
    sizej = buj + bvj
    ri, rj = b[i, Body.RADIUS], b[j, Body.RADIUS]
    dx = xj - xi
    dz = zj - zi
    cu = dx * ci + dz * si  # j's centre in i's frame
    cv = -dx * si + dz * ci
    touch = ri + rj + rch
    # j's tilt relative to i, and i's centre in j's frame
    c = ci * cj + si * sj
    s = sj * ci - cj * si
    tu = -cu * c - cv * s
    tv = cu * s - cv * c
    # weighted sums of (1, contact point u, v, normal u, v): by motion - gap, and by
    # rch - gap for a standby contact
    near = ti.Vector([0.0, 0.0, 0.0, 0.0, 0.0])
    standby = ti.Vector([0.0, 0.0, 0.0, 0.0, 0.0])
    gap = FAR
    touch2 = touch * touch
    # i's list entry for j, if any, and whether it still holds every pair within touch:
    # any disc of i has moved relative to j's discs by at most |dt| + |dR| bound_i since
    # the list was made (|dR| <= |dc| + |ds| for the rotation), so a pair within touch now
    # was within touch + that then; ``slack`` covers the round-off of both computations
    # (64 epsilon of the coordinates' size: 1e-11 in f64 at |x| ~ 1000, 1e-2 in f32)
    lists = a.cfg[Config.LISTS] != 0
    entry = -1
    use = False
    if lists:
        for e in ti.static(range(ENTRIES)):
            if a.nl[i, list_partner(e)] == j:
                entry = e
    if entry >= 0:
        if a.nl[i, list_count(entry)] >= 0:
            pose = ti.static(a.nr)
            moved = ti.abs(tu - pose[i, entry, ListPose.TU]) + ti.abs(tv - pose[i, entry, ListPose.TV])
            moved += (ti.abs(c - pose[i, entry, ListPose.C]) + ti.abs(s - pose[i, entry, ListPose.S])) * b[i, Body.BOUND]
            size = ti.abs(xi) + ti.abs(zi) + ti.abs(xj) + ti.abs(zj) + b[i, Body.BOUND] + b[j, Body.BOUND] + touch
            use = touch + moved + 64.0 * a.par[Param.EPS] * size <= pose[i, entry, ListPose.KEEP]
    if use:
        fa_prev = -1
        fb_prev = -1
        au0, av0, dau, dav = 0.0, 0.0, 0.0, 0.0
        pu, pv, dub, dvb, st = 0.0, 0.0, 0.0, 0.0, 0.0
        base = list_code(entry, 0, runs)
        for q in range(a.nl[i, list_count(entry)]):
            code = a.nl[i, base + q]
            fa, ia, fb, ib0 = unpack_pair(code)
            if fa != fa_prev:
                fa_prev = fa
                u0, v0, du, dv, length, n = edge_line(a, i, fa, k, hwi, hhi, ri)
                au0, av0, dau, dav = face_in_j(u0, v0, du, dv, length, n, cu, cv, c, s)
            if fb != fb_prev:  # the runs of one disc of i, and of the next, mostly face one edge of j
                fb_prev = fb
                pu, pv, dub, dvb, lb, nb = edge_line(a, j, fb, k, hwj, hhj, rj)
                st, _inv = edge_spacing(lb, nb, sizej)
            au = au0 + ia * dau
            av = av0 + ia * dav
            perp, along = j_face(au, av, pu, pv, dub, dvb)
            for ib in range(ib0, ib0 + (code >> _LEN_SHIFT)):
                off = along - ib * st
                d2 = perp * perp + off * off
                if d2 < touch2 and d2 > 0:
                    near, standby, gap = add_pair(perp, off, dub, dvb, d2, au, av, ri, rj, motion, rch, near, standby, gap)
    else:
        # search, keeping the pairs within touch + skin in a (new or reused) list entry
        skin = 0.0
        count = -1  # -1: nothing kept
        if lists:
            skin = SKIN * ti.min(ri, rj)
            if entry < 0:
                entry = a.bi[i, BodyInt.NEXT_ENTRY]
                a.bi[i, BodyInt.NEXT_ENTRY] = (entry + 1) % ENTRIES
            if ti.max(edge_discs(a, i, k), edge_discs(a, j, k)) <= MAX_FACE_DISCS:
                count = 0  # else the indices do not fit the list's codes: always search
        keep = touch + skin
        keep2 = keep * keep
        last = -1  # the last pair kept (its code without the run length)
        grow = rch + skin
        faces = edges(a, i)
        if boxes_apart(cu, cv, c, s, bui, bvi, buj, bvj, grow):
            faces = 0  # the boxes (which contain the discs) cannot meet this step
        faces_j = edges(a, j)
        lim_u, lim_v = grown(buj, bvj, ri, grow)
        for fa in range(faces):
            # i's discs on this edge, in j's frame, are (au0, av0) + ia (dau, dav): keep
            # those inside j's box grown by ri + rch + skin (the exact test is per disc)
            u0, v0, du, dv, length, n = edge_line(a, i, fa, k, hwi, hhi, ri)
            au0, av0, dau, dav = face_in_j(u0, v0, du, dv, length, n, cu, cv, c, s)
            lo_a, hi_a = line_window(au0, dau, lim_u, 0, n - 1)
            if lo_a <= hi_a:
                lo_a, hi_a = line_window(av0, dav, lim_v, lo_a, hi_a)
            for ia in range(lo_a, hi_a + 1):
                au = au0 + ia * dau  # disc of i in j's frame
                av = av0 + ia * dav
                if ti.abs(au) > lim_u or ti.abs(av) > lim_v:
                    continue
                # j's edges (a dynamic loop: unrolled, the kernels took twice as long to
                # compile, for ~10% of this loop's time)
                for fb in range(faces_j):
                    pu, pv, dub, dvb, lb, nb = edge_line(a, j, fb, k, hwj, hhj, rj)
                    st, inv_st = edge_spacing(lb, nb, sizej)
                    perp, along = j_face(au, av, pu, pv, dub, dvb)
                    if ti.abs(perp) < keep:
                        lo_b, hi_b = 0, nb - 1
                        if inv_st > 0:
                            lo_b = ti.max(0, ti.cast(ti.ceil((along - keep) * inv_st), ti.i32))
                            hi_b = ti.min(nb - 1, ti.cast(ti.floor((along + keep) * inv_st), ti.i32))
                        for ib in range(lo_b, hi_b + 1):
                            off = along - ib * st
                            d2 = perp * perp + off * off
                            if d2 < keep2 and count >= 0:
                                key = pack_pair(fa, ia, fb, ib)
                                if count > 0 and key == last + 1 and ib > 0:
                                    # the next disc of j after the last kept: extend its run
                                    a.nl[i, list_code(entry, count - 1, runs)] += 1 << _LEN_SHIFT
                                    last = key
                                elif count < runs:
                                    a.nl[i, list_code(entry, count, runs)] = key | (1 << _LEN_SHIFT)
                                    last = key
                                    count += 1
                                else:
                                    count = -1  # too many runs to keep: search next step
                            if d2 < touch2 and d2 > 0:
                                near, standby, gap = add_pair(
                                    perp, off, dub, dvb, d2, au, av, ri, rj, motion, rch, near, standby, gap
                                )
        if lists:
            a.nl[i, list_partner(entry)] = j
            a.nl[i, list_count(entry)] = count
            a.nr[i, entry, ListPose.TU] = tu
            a.nr[i, entry, ListPose.TV] = tv
            a.nr[i, entry, ListPose.C] = c
            a.nr[i, entry, ListPose.S] = s
            a.nr[i, entry, ListPose.KEEP] = keep
    if gap < rch:
        merge(a, i, j, near, standby, gap, xi, zi, xj, zj, cj, sj)


@ti.func
def merge(a: ti.template(), i, j, near, standby, gap, xi, zi, xj, zj, cj, sj):
    """The pair's one contact from its disc pairs' sums (in j's frame): the closing pairs'
    (``near``), or, if none closes, the standby sums; the poses as the caller read them."""
    sums = near
    if near[0] <= 0:
        sums = standby
    wsum = sums[0]
    qu = sums[1] / wsum
    qv = sums[2] / wsum
    nx = sums[3] * cj - sums[4] * sj
    nz = sums[3] * sj + sums[4] * cj
    nn = ti.sqrt(nx * nx + nz * nz)
    if nn <= TINY * wsum:
        # symmetric overlap: the disc normals cancel; push along the centre line instead
        nx = xi - xj
        nz = zi - zj
        nn = ti.sqrt(nx * nx + nz * nz)
        if nn <= 0:
            nx = 1.0
            nz = 0.0
            nn = 1.0
    insert_contact(a, i, j, xj + qu * cj - qv * sj, zj + qu * sj + qv * cj, nx / nn, nz / nn, gap)


@ti.func
def detect(fx: ti.template(), a: ti.template(), i, size):
    """Contacts of body i with partners j > i (slots sorted by j), and with the wall; with
    crushing, what each has passed this step starts at 0 (a detection again within a step
    starts it afresh)."""
    b = ti.static(a.b)
    a.bi[i, BodyInt.NCONTACT] = 0
    if ti.static(fx.crushing):
        for s in range(ti.cast(a.cfg[Config.SLOTS], ti.i32) + 1):
            a.cd[s, i, Contact.SPENT] = 0.0
    if ti.static(fx.collisions):
        ncells = a.cfg[Config.NCELLS]
        xi = b[i, Body.X]
        zi = b[i, Body.Z]
        home = ti.cast(ti.floor(xi / size), ti.i64)
        mg = margin(a)
        rch_i = reach(a, i, mg)
        for dc in ti.static(range(-1, 2)):
            cell = ti.cast((home + dc) & (ncells - 1), ti.i32)
            for slot in range(a.cells[cell, Cell.START], a.cells[cell + 1, Cell.START]):
                j = a.bi[slot, BodyInt.SORTED]
                if j > i:
                    rch = rch_i + reach(a, j, mg)
                    dx = xi - b[j, Body.X]
                    dz = zi - b[j, Body.Z]
                    lim = b[i, Body.BOUND] + b[j, Body.BOUND] + rch
                    if dx * dx + dz * dz < lim * lim:
                        if not held(fx, a, i, j):
                            narrow(a, i, j, rch, b[i, Body.MOTION] + b[j, Body.MOTION])
    if ti.static(fx.wall):
        if not held_wall(fx, a, i):
            wall.detect(a, i)
        else:
            a.bi[i, BodyInt.WALL_ON] = 0


@ti.func
def held(fx: ti.template(), a: ti.template(), i, j) -> ti.i32:
    """1 if a named effect holds the pair's contact (its ``joined`` term: an intact bond)."""
    out = 0
    for e in ti.static(JOINED):
        if ti.static(e.on(fx)):
            out = out | ti.static(term_of(e, "joined"))(a, i, j)
    return out


@ti.func
def held_wall(fx: ti.template(), a: ti.template(), i) -> ti.i32:
    """1 if a named effect holds body i's wall contact."""
    out = 0
    for e in ti.static(JOINED_WALL):
        if ti.static(e.on(fx)):
            out = out | ti.static(term_of(e, "joined_wall"))(a, i)
    return out


@ti.func
def narrow_stage(fx: ti.template(), a: ti.template()):
    """The stage: every body's contacts (parallel over bodies in the parallel form)."""
    size = cell_size(a)
    for i in range(a.b.shape[0]):
        detect(fx, a, i, size)

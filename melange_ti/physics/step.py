"""One time step as named phases, and the kernels that run them (Taichi).

Kernels take the model's ndarrays as arguments and the frozen effect set ``fx`` as a
template, so they compile once per effect set (and precision) and are reused by every model
of any size; parameters such as ``dt`` are read at run time from ``par``. Every term is
guarded by ``ti.static(fx.<effect>)``: an effect the scene does not name is not compiled.

Phases (semi-implicit Euler, velocities first):

1. ``kick``      v += dt F/m, omega += dt tau/I (gravity, buoyancy), then linear drag as
                 v /= (1 + c dt) (backward Euler for the drag term: unconditionally stable,
                 never reverses a velocity); drag's exact energy loss is booked per body.
2. ``reach``     per-body bound on how far any point of the body moves this step, with
                 room for what one impulse from the fastest body could add.
3. ``bin``       counting sort of body centres into hashed cells along x.
4. ``detect``    (parallel) bounding circles inflated by the reach, then discs of candidate
                 pairs; all disc pairs of one body pair merge into one contact, stored in
                 per-body slots sorted by partner index (independent of the thread count).
                 A contact is kept if its gap may close within this step (speculative
                 contacts: no tunnelling at any speed). In the serial form each body keeps,
                 per partner, the disc pairs within touching distance plus a skin, and
                 visits only those while the pair has not moved by more than the skin
                 allows (``narrow``): the same contacts, bit for bit, for less work.
5. ``impulses``  sequential, fixed order: body i ascending, its wall contact first, then its
                 partners j > i ascending; repeated ``contact_passes`` times. Then, only in
                 violent cases: while some contact would still close by more than
                 ``DEEP_FRACTION`` of a disc radius this step, the pass runs again, and if an
                 impulse made a body faster than the reach it was searched with (a struck
                 iceberg in a packed row), detection runs again first (at most
                 ``MAX_DETECT`` rounds), so chains cannot tunnel.
6. ``drift``     x += dt v, theta += dt omega; cos and sin of the new tilt are cached
                 (COS, SIN) for the correction, the next step's forces and contacts: the
                 one place a step evaluates trigonometric functions.
7. ``correct``   sequential, same order: the overlap left after the drift (estimated from
                 the contact gap, the final velocities and earlier pushes) is removed along
                 the normal, split by inverse mass; its potential-energy change is booked.
                 Sweeps repeat (at most ``MAX_CORRECT``) until none pushes, so a push that
                 drives a body back into the wall or a third body is undone too.
"""

import taichi as ti

from .contacts import cross2, disc_local, face_line, line_window, to_world
from .hydrostatics import potential_energy, submerged_moments
from .layout import (
    ACC_COLLISION,
    ACC_CORRECTION,
    ACC_IMPULSE,
    ACC_WALL_IMPULSE,
    AGAIN,
    BOUND,
    BOUND_MAX,
    CELL,
    CGAP,
    CNX,
    CNZ,
    CONTACTS,
    COS,
    COUNT,
    CPX,
    CPZ,
    DEEP_FRACTION,
    DISCS,
    DRAG_ANG,
    DRAG_LIN,
    DRAG_WORK,
    DT,
    ENTRIES,
    EPS,
    FILL,
    INERTIA,
    INV_MASS,
    KINETIC,
    LISTS,
    MASS,
    MAX_CORRECT,
    MAX_DETECT,
    MOTION,
    NCELLS,
    NCONTACT,
    NEXT_ENTRY,
    OM,
    OVERFLOW,
    PAIRS,
    PASSES,
    POTENTIAL,
    PUSHED,
    RADIUS,
    REACH,
    REACH_MAX,
    RESTITUTION,
    SHIFT_X,
    SHIFT_Z,
    SIN,
    SKIN,
    SLOTS,
    SORTED,
    SPEED_MAX,
    START,
    TH,
    THICK,
    VX,
    VZ,
    WALL_GAP,
    WALL_ON,
    WALL_PZ,
    WALL_X,
    WATER,
    WIDTH,
    K,
    N,
    X,
    Z,
)

arr = ti.types.ndarray()


# ---------------------------------------------------------------- forces and integration
@ti.func
def kick(fx: ti.template(), b: ti.template(), par: ti.template(), i):
    dt = par[DT]
    m = b[i, MASS]
    fz = 0.0
    tau = 0.0
    if ti.static(fx.gravity):
        fz -= m
    if ti.static(fx.buoyancy):
        mo = submerged_moments(b[i, Z], b[i, COS], b[i, SIN], 0.5 * b[i, WIDTH], 0.5 * b[i, THICK], par[WATER])
        fz += mo[0]
        tau += mo[1]
    if ti.static(fx.gravity or fx.buoyancy):
        b[i, VZ] += dt * fz / m
    if ti.static(fx.buoyancy):
        b[i, OM] += dt * tau / b[i, INERTIA]
    if ti.static(fx.drag):
        vx, vz, om = b[i, VX], b[i, VZ], b[i, OM]
        lin = 1.0 / (1.0 + par[DRAG_LIN] * dt)
        ang = 1.0 / (1.0 + par[DRAG_ANG] * dt)
        b[i, VX] = vx * lin
        b[i, VZ] = vz * lin
        b[i, OM] = om * ang
        b[i, DRAG_WORK] += 0.5 * m * (vx * vx + vz * vz) * (1.0 - lin * lin) + 0.5 * b[i, INERTIA] * om * om * (1.0 - ang * ang)


@ti.func
def orient(b: ti.template(), i):
    """Cache cos and sin of body i's tilt (COS, SIN): the one place a step evaluates them."""
    b[i, COS] = ti.cos(b[i, TH])
    b[i, SIN] = ti.sin(b[i, TH])


@ti.func
def drift(b: ti.template(), par: ti.template(), i):
    dt = par[DT]
    b[i, X] += dt * b[i, VX]
    b[i, Z] += dt * b[i, VZ]
    b[i, TH] += dt * b[i, OM]
    orient(b, i)


@ti.func
def body_energy(fx: ti.template(), b: ti.template(), par: ti.template(), i):
    return potential_energy(
        b[i, Z],
        b[i, COS],
        b[i, SIN],
        0.5 * b[i, WIDTH],
        0.5 * b[i, THICK],
        b[i, MASS],
        par[WATER],
        ti.static(fx.gravity),
        ti.static(fx.buoyancy),
    )


@ti.func
def outran(b: ti.template(), par: ti.template(), i):
    """1 if body i now moves farther this step than the reach it was searched with."""
    return ti.cast(par[DT] * speed(b, i) > b[i, REACH] * (1.0 + 1e-9) + 1e-12, ti.i32)


# ---------------------------------------------------------------- broad phase
@ti.func
def speed(b: ti.template(), i):
    """Fastest speed of any point of body i."""
    return ti.sqrt(b[i, VX] ** 2 + b[i, VZ] ** 2) + ti.abs(b[i, OM]) * b[i, BOUND]


@ti.func
def reach(b: ti.template(), par: ti.template(), i):
    """How far body i may move this step, including what an impulse from the fastest body
    could add, ``(1 + e) * SPEED_MAX``. (A chain of impulses can exceed even that; then the
    step detects again, see ``outran``.)"""
    motion = par[DT] * speed(b, i)
    b[i, MOTION] = motion
    r = motion + par[DT] * (1.0 + par[RESTITUTION]) * par[SPEED_MAX]
    b[i, REACH] = r
    return r


@ti.func
def cell_size(par: ti.template()):
    # Bodies closer than the sum of their inflated bounding radii lie in adjacent cells.
    return 2.0 * (par[BOUND_MAX] + par[REACH_MAX]) + 1e-9


@ti.func
def cell_of(x, size, ncells):
    return ti.cast(ti.cast(ti.floor(x / size), ti.i64) & (ncells - 1), ti.i32)


@ti.func
def scan_cells(cells: ti.template(), ncells):
    total = 0
    for c in range(ti.cast(ncells, ti.i32)):
        cells[c, START] = total
        cells[c, FILL] = total
        total += cells[c, COUNT]
        cells[c, COUNT] = 0
    cells[ncells, START] = total


# ---------------------------------------------------------------- narrow phase
@ti.func
def insert_contact(bi: ti.template(), cd: ti.template(), cp: ti.template(), ipar: ti.template(), i, j, px, pz, nx, nz, gap):
    cnt = bi[i, NCONTACT]
    if cnt >= ipar[SLOTS]:
        ipar[OVERFLOW] = 1
    else:
        pos = cnt
        while pos > 0 and cp[pos - 1, i] > j:
            cp[pos, i] = cp[pos - 1, i]
            for c in ti.static(range(5)):
                cd[pos, i, c] = cd[pos - 1, i, c]
            pos -= 1
        cp[pos, i] = j
        cd[pos, i, CPX] = px
        cd[pos, i, CPZ] = pz
        cd[pos, i, CNX] = nx
        cd[pos, i, CNZ] = nz
        cd[pos, i, CGAP] = gap
        bi[i, NCONTACT] = cnt + 1


@ti.func
def boxes_apart(cu, cv, c, s, hwi, hhi, hwj, hhj, gap):
    """Separating-axis test of two rectangles, in i's frame: j's centre (cu, cv), j's tilt
    relative to i (cos c, sin s). True when they are more than ``gap`` apart on some axis."""
    ac = ti.abs(c)
    as_ = ti.abs(s)
    # i's axes
    far = ti.abs(cu) > hwi + hwj * ac + hhj * as_ + gap or ti.abs(cv) > hhi + hwj * as_ + hhj * ac + gap
    # j's axes: u_j = (c, s), v_j = (-s, c)
    pu = cu * c + cv * s
    pv = -cu * s + cv * c
    far = far or ti.abs(pu) > hwj + hwi * ac + hhi * as_ + gap or ti.abs(pv) > hhj + hwi * as_ + hhi * ac + gap
    return far


@ti.func
def face_in_j(fa, k, hwi, hhi, ri, cu, cv, c, s):
    """i's face ``fa`` in j's frame: its discs are at ``(au0, av0) + ia (dau, dav)``. j's
    centre is at (cu, cv) in i's frame, and (c, s) is j's tilt relative to i."""
    u0, v0, du, dv, length = face_line(fa, hwi, hhi, ri)
    step = length / k
    eu = u0 - cu
    ev = v0 - cv
    return eu * c + ev * s, -eu * s + ev * c, step * (du * c + dv * s), step * (-du * s + dv * c)


@ti.func
def j_face(fb, au, av, iuj, ivj, stu, stv, inv_stu, inv_stv):
    """For a disc of i at (au, av) in j's frame and j's face ``fb``: its offset across the
    face (``perp``) and along it from the face's first disc (``along``), and the face's disc
    spacing and its inverse. Face fb's disc ``ib`` is ``along - ib * st`` away along it."""
    perp = au - iuj
    along = av + ivj
    st = stv
    inv_st = inv_stv
    if fb == 1:
        perp, along, st, inv_st = av - ivj, iuj - au, stu, inv_stu
    elif fb == 2:
        perp, along = au + iuj, ivj - av
    elif fb == 3:
        perp, along, st, inv_st = av + ivj, au + iuj, stu, inv_stu
    return perp, along, st, inv_st


@ti.func
def pair_term(fb, perp, a, d2, au, av, ri, rj):
    """Gap and weighted-sum term (1, contact point u, v, normal u, v; j's frame) of the disc
    pair at offset (perp, a) from j's disc on face fb, ``d2 = perp^2 + a^2 > 0``."""
    # offset from j's disc to i's disc, in j's frame
    du_, dv_ = perp, a
    if fb == 1:
        du_, dv_ = -a, perp
    elif fb == 2:
        du_, dv_ = perp, -a
    elif fb == 3:
        du_, dv_ = a, perp
    dist = ti.sqrt(d2)
    g = dist - ri - rj
    inv = 1.0 / dist
    t = (rj + 0.5 * g) * inv
    return g, ti.Vector([1.0, au - du_ + du_ * t, av - dv_ + dv_ * t, du_ * inv, dv_ * inv])


@ti.func
def narrow(
    b: ti.template(),
    bi: ti.template(),
    cd: ti.template(),
    cp: ti.template(),
    nl: ti.template(),
    nr: ti.template(),
    par: ti.template(),
    ipar: ti.template(),
    i,
    j,
    rch,
    motion,
):
    """One contact for the pair (i, j) from its disc pairs.

    Disc pairs closer than ``motion`` (how far the pair can close at its current
    velocities) merge into one contact, weighted by ``motion - gap``. If none is that close
    but some are within ``rch`` (room for velocities an impulse may add), those merge,
    weighted by ``rch - gap``, into a standby contact, so a struck iceberg meets its
    neighbour. Sums are taken in j's body frame, over the disc pairs within touching
    distance in a fixed order (i's face, i's disc, j's face, j's disc).

    Finding those pairs: on each face of i, the discs within reach of j's box; for each, on
    each face of j, the discs within reach of it (an index range from its distance along the
    face). Where lists are on (``ipar[LISTS]``: the serial form up to ``LISTS_MAX_N``
    icebergs), that search also keeps, in i's candidate list for j (``nl``, ``nr``), every
    disc pair within touching distance plus a skin, in the same order, with the pair's
    relative pose. While neither body has moved relative to the other by more than the skin allows,
    later steps visit only the kept pairs. They contain every pair within touching distance
    and the order is the same, so a contact is bit-for-bit the same either way; the list
    only saves the search.
    """
    k = ti.cast(ipar[K], ti.i32)
    ci, si, cj, sj = b[i, COS], b[i, SIN], b[j, COS], b[j, SIN]
    xi, zi, xj, zj = b[i, X], b[i, Z], b[j, X], b[j, Z]
    hwi, hhi, ri = 0.5 * b[i, WIDTH], 0.5 * b[i, THICK], b[i, RADIUS]
    hwj, hhj, rj = 0.5 * b[j, WIDTH], 0.5 * b[j, THICK], b[j, RADIUS]
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
    gap = 1e30
    touch2 = touch * touch
    # j's disc-centre rectangle and its disc spacing along the u- and v-faces (a face of
    # zero length holds k coincident discs: every index is then in range)
    iuj = hwj - rj
    ivj = hhj - rj
    stu = 2.0 * iuj / k
    stv = 2.0 * ivj / k
    inv_stu = 0.0
    inv_stv = 0.0
    if stu > 1e-12 * (hwj + hhj):
        inv_stu = 1.0 / stu
    if stv > 1e-12 * (hwj + hhj):
        inv_stv = 1.0 / stv
    # i's list entry for j, if any, and whether it still holds every pair within touch:
    # any disc of i has moved relative to j's discs by at most |dt| + |dR| bound_i since
    # the list was made (|dR| <= |dc| + |ds| for the rotation), so a pair within touch now
    # was within touch + that then; ``slack`` covers the round-off of both computations
    # (64 epsilon of the coordinates' size: 1e-11 in f64 at |x| ~ 1000, 1e-2 in f32)
    lists = ipar[LISTS] != 0
    entry = -1
    use = False
    if lists:
        for e in ti.static(range(ENTRIES)):
            if nl[i, e] == j:
                entry = e
    if entry >= 0:
        if nl[i, ENTRIES + entry] >= 0:
            moved = ti.abs(tu - nr[i, entry, 0]) + ti.abs(tv - nr[i, entry, 1])
            moved += (ti.abs(c - nr[i, entry, 2]) + ti.abs(s - nr[i, entry, 3])) * b[i, BOUND]
            size = ti.abs(xi) + ti.abs(zi) + ti.abs(xj) + ti.abs(zj) + b[i, BOUND] + b[j, BOUND] + touch
            use = touch + moved + 64.0 * par[EPS] * size <= nr[i, entry, 4]
    if use:
        fa_prev = -1
        au0, av0, dau, dav = 0.0, 0.0, 0.0, 0.0
        base = 2 * ENTRIES + entry * PAIRS
        for q in range(nl[i, ENTRIES + entry]):
            code = nl[i, base + q]
            fa = code >> 14
            ia = (code >> 8) & 63
            fb = (code >> 6) & 3
            ib = code & 63
            if fa != fa_prev:
                fa_prev = fa
                au0, av0, dau, dav = face_in_j(fa, k, hwi, hhi, ri, cu, cv, c, s)
            au = au0 + ia * dau
            av = av0 + ia * dav
            perp, along, st, _inv = j_face(fb, au, av, iuj, ivj, stu, stv, inv_stu, inv_stv)
            a = along - ib * st
            d2 = perp * perp + a * a
            if d2 < touch2 and d2 > 0:
                g, term = pair_term(fb, perp, a, d2, au, av, ri, rj)
                if g < motion:
                    near += (motion - g) * term
                standby += (rch - g) * term
                gap = ti.min(gap, g)
    else:
        # search, keeping the pairs within touch + skin in a (new or reused) list entry
        skin = 0.0
        count = -1  # -1: nothing kept
        if lists:
            skin = SKIN * ti.min(ri, rj)
            if entry < 0:
                entry = bi[i, NEXT_ENTRY]
                bi[i, NEXT_ENTRY] = (entry + 1) % ENTRIES
            if k <= 64:  # else the indices do not fit the list's codes: always search
                count = 0
        keep = touch + skin
        keep2 = keep * keep
        grow = rch + skin
        faces = 4
        if boxes_apart(cu, cv, c, s, hwi, hhi, hwj, hhj, grow):
            faces = 0  # the rectangles (which contain the discs) cannot meet this step
        lim_u = hwj + ri + grow
        lim_v = hhj + ri + grow
        for fa in range(faces):
            lo_a, hi_a = 0, k - 1
            # i's discs on this face, in j's frame, are (au0, av0) + ia (dau, dav): keep
            # those inside j's box grown by ri + rch + skin (the exact test is per disc)
            au0, av0, dau, dav = face_in_j(fa, k, hwi, hhi, ri, cu, cv, c, s)
            lo_a, hi_a = line_window(au0, dau, lim_u, lo_a, hi_a)
            if lo_a <= hi_a:
                lo_a, hi_a = line_window(av0, dav, lim_v, lo_a, hi_a)
            for ia in range(lo_a, hi_a + 1):
                au = au0 + ia * dau  # disc of i in j's frame
                av = av0 + ia * dav
                if ti.abs(au) > lim_u or ti.abs(av) > lim_v:
                    continue
                # j's faces are axis-aligned in its frame (a dynamic loop: unrolled, the
                # kernels took twice as long to compile, for ~10% of this loop's time)
                for fb in range(4):
                    perp, along, st, inv_st = j_face(fb, au, av, iuj, ivj, stu, stv, inv_stu, inv_stv)
                    if ti.abs(perp) < keep:
                        lo_b, hi_b = 0, k - 1
                        if inv_st > 0:
                            lo_b = ti.max(0, ti.cast(ti.ceil((along - keep) * inv_st), ti.i32))
                            hi_b = ti.min(k - 1, ti.cast(ti.floor((along + keep) * inv_st), ti.i32))
                        for ib in range(lo_b, hi_b + 1):
                            a = along - ib * st
                            d2 = perp * perp + a * a
                            if d2 < keep2 and count >= 0:
                                if count < PAIRS:
                                    nl[i, 2 * ENTRIES + entry * PAIRS + count] = (fa << 14) | (ia << 8) | (fb << 6) | ib
                                    count += 1
                                else:
                                    count = -1  # too many pairs to keep: search next step
                            if d2 < touch2 and d2 > 0:
                                g, term = pair_term(fb, perp, a, d2, au, av, ri, rj)
                                if g < motion:
                                    near += (motion - g) * term
                                standby += (rch - g) * term
                                gap = ti.min(gap, g)
        if lists:
            nl[i, entry] = j
            nl[i, ENTRIES + entry] = count
            nr[i, entry, 0] = tu
            nr[i, entry, 1] = tv
            nr[i, entry, 2] = c
            nr[i, entry, 3] = s
            nr[i, entry, 4] = keep
    if gap < rch:
        sums = near
        if near[0] <= 0:
            sums = standby
        wsum = sums[0]
        qu = sums[1] / wsum
        qv = sums[2] / wsum
        nx = sums[3] * cj - sums[4] * sj
        nz = sums[3] * sj + sums[4] * cj
        nn = ti.sqrt(nx * nx + nz * nz)
        if nn <= 1e-12 * wsum:
            # symmetric overlap: the disc normals cancel; push along the centre line instead
            nx = xi - xj
            nz = zi - zj
            nn = ti.sqrt(nx * nx + nz * nz)
            if nn <= 0:
                nx = 1.0
                nz = 0.0
                nn = 1.0
        insert_contact(bi, cd, cp, ipar, i, j, xj + qu * cj - qv * sj, zj + qu * sj + qv * cj, nx / nn, nz / nn, gap)


@ti.func
def wall_gap(b: ti.template(), par: ti.template(), ipar: ti.template(), i):
    """Smallest gap between body i's discs and the wall at the current position."""
    k = ti.cast(ipar[K], ti.i32)
    c, s = b[i, COS], b[i, SIN]
    hw, hh, r = 0.5 * b[i, WIDTH], 0.5 * b[i, THICK], b[i, RADIUS]
    gap = 1e30
    for a in range(ti.cast(ipar[DISCS], ti.i32)):
        pa = to_world(disc_local(a, k, hw, hh, r), b[i, X], b[i, Z], c, s)
        gap = ti.min(gap, pa[0] - r - par[WALL_X])
    return gap


@ti.func
def detect_wall(b: ti.template(), bi: ti.template(), par: ti.template(), ipar: ti.template(), i):
    c, s = b[i, COS], b[i, SIN]
    hw, hh, r = 0.5 * b[i, WIDTH], 0.5 * b[i, THICK], b[i, RADIUS]
    rch = b[i, REACH]
    motion = b[i, MOTION]
    wall_x = par[WALL_X]
    bi[i, WALL_ON] = 0
    if b[i, X] - b[i, BOUND] - rch < wall_x:
        k = ti.cast(ipar[K], ti.i32)
        wsum = 0.0
        pz = 0.0
        wsum2 = 0.0
        pz2 = 0.0
        gap = 1e30
        for a in range(ti.cast(ipar[DISCS], ti.i32)):
            pa = to_world(disc_local(a, k, hw, hh, r), b[i, X], b[i, Z], c, s)
            g = pa[0] - r - wall_x
            if g < rch:
                if g < motion:
                    wsum += motion - g
                    pz += (motion - g) * pa[1]
                wsum2 += rch - g
                pz2 += (rch - g) * pa[1]
                gap = ti.min(gap, g)
        if gap < rch:
            bi[i, WALL_ON] = 1
            b[i, WALL_PZ] = pz / wsum if wsum > 0 else pz2 / wsum2
            b[i, WALL_GAP] = gap


@ti.func
def detect(
    fx: ti.template(),
    b: ti.template(),
    bi: ti.template(),
    cd: ti.template(),
    cp: ti.template(),
    nl: ti.template(),
    nr: ti.template(),
    cells: ti.template(),
    par: ti.template(),
    ipar: ti.template(),
    i,
    size,
):
    """Contacts of body i with partners j > i (slots sorted by j), and with the wall."""
    bi[i, NCONTACT] = 0
    if ti.static(fx.collisions):
        ncells = ipar[NCELLS]
        xi = b[i, X]
        zi = b[i, Z]
        home = ti.cast(ti.floor(xi / size), ti.i64)
        for dc in ti.static(range(-1, 2)):
            cell = ti.cast((home + dc) & (ncells - 1), ti.i32)
            for slot in range(cells[cell, START], cells[cell + 1, START]):
                j = bi[slot, SORTED]
                if j > i:
                    rch = b[i, REACH] + b[j, REACH]
                    dx = xi - b[j, X]
                    dz = zi - b[j, Z]
                    lim = b[i, BOUND] + b[j, BOUND] + rch
                    if dx * dx + dz * dz < lim * lim:
                        narrow(b, bi, cd, cp, nl, nr, par, ipar, i, j, rch, b[i, MOTION] + b[j, MOTION])
    if ti.static(fx.wall):
        detect_wall(b, bi, par, ipar, i)


# ---------------------------------------------------------------- impulses and corrections
@ti.func
def normal_speed(b: ti.template(), i, j, rx1, rz1, rx2, rz2, nx, nz):
    """Normal relative velocity at the contact; j < 0 is the wall (at rest)."""
    v1x = b[i, VX] - b[i, OM] * rz1
    v1z = b[i, VZ] + b[i, OM] * rx1
    v2x = 0.0
    v2z = 0.0
    if j >= 0:
        v2x = b[j, VX] - b[j, OM] * rz2
        v2z = b[j, VZ] + b[j, OM] * rx2
    return (v1x - v2x) * nx + (v1z - v2z) * nz


@ti.func
def resolve(b: ti.template(), par: ti.template(), acc: ti.template(), ipar: ti.template(), i, j, px, pz, nx, nz, gap):
    """Apply the SPEC impulse to the pair (i, j) (j < 0: the wall) if it approaches."""
    rx1 = px - b[i, X]
    rz1 = pz - b[i, Z]
    rx2 = 0.0
    rz2 = 0.0
    if j >= 0:
        rx2 = px - b[j, X]
        rz2 = pz - b[j, Z]
    vn = normal_speed(b, i, j, rx1, rz1, rx2, rz2, nx, nz)
    if vn < 0 and gap + par[DT] * vn < 0:
        e = par[RESTITUTION]
        n = ti.Vector([nx, nz])
        a1 = cross2(ti.Vector([rx1, rz1]), n)
        kk = b[i, INV_MASS] + a1 * a1 / b[i, INERTIA]
        a2 = 0.0
        if j >= 0:
            a2 = cross2(ti.Vector([rx2, rz2]), n)
            kk += b[j, INV_MASS] + a2 * a2 / b[j, INERTIA]
        jn = -(1.0 + e) * vn / kk
        b[i, VX] += jn * nx / b[i, MASS]
        b[i, VZ] += jn * nz / b[i, MASS]
        b[i, OM] += a1 * jn / b[i, INERTIA]
        if j >= 0:
            b[j, VX] -= jn * nx / b[j, MASS]
            b[j, VZ] -= jn * nz / b[j, MASS]
            b[j, OM] -= a2 * jn / b[j, INERTIA]
        else:
            acc[ACC_WALL_IMPULSE] += jn
        acc[ACC_COLLISION] += 0.5 * (1.0 - e * e) * vn * vn / kk
        acc[ACC_IMPULSE] += jn
        ipar[CONTACTS] += 1


@ti.func
def predicted_gap(b: ti.template(), par: ti.template(), i, j, px, pz, nx, nz, gap):
    """Gap of the contact (i, j) at the end of the step: its gap when found, advanced
    linearly with the final velocities (arms from the bodies' positions at the start of
    the step). Call after the drift and before any correction."""
    dt = par[DT]
    rx1 = px - (b[i, X] - dt * b[i, VX])
    rz1 = pz - (b[i, Z] - dt * b[i, VZ])
    rx2 = px - (b[j, X] - dt * b[j, VX])
    rz2 = pz - (b[j, Z] - dt * b[j, VZ])
    return gap + dt * normal_speed(b, i, j, rx1, rz1, rx2, rz2, nx, nz)


@ti.func
def push(
    fx: ti.template(),
    b: ti.template(),
    bi: ti.template(),
    par: ti.template(),
    ipar: ti.template(),
    sweep,
    i,
    j,
    nx,
    nz,
    g_end,
):
    """Remove the overlap left after the drift, split by inverse mass (pair centre fixed).

    Between two icebergs the overlap is ``g_end`` (:func:`predicted_gap`) plus the pushes
    so far along the normal; at the wall (j < 0, normal fixed) it is measured exactly from
    the discs. A body moved for the first time in this pass records its potential energy
    (POTENTIAL column) and is marked with the sweep (PUSHED); the pass books the energy
    change per body."""
    inv1 = b[i, INV_MASS]
    inv2 = 0.0
    g = 0.0
    if j >= 0:
        inv2 = b[j, INV_MASS]
        g = g_end + (b[i, SHIFT_X] - b[j, SHIFT_X]) * nx + (b[i, SHIFT_Z] - b[j, SHIFT_Z]) * nz
    else:
        g = wall_gap(b, par, ipar, i)
    pushed = 0
    if g < -1e-12:
        pushed = 1
        depth = -g
        if bi[i, PUSHED] < 0:
            b[i, POTENTIAL] = body_energy(fx, b, par, i)
        bi[i, PUSHED] = sweep
        s1 = depth * inv1 / (inv1 + inv2)
        b[i, X] += s1 * nx
        b[i, Z] += s1 * nz
        b[i, SHIFT_X] += s1 * nx
        b[i, SHIFT_Z] += s1 * nz
        if j >= 0:
            if bi[j, PUSHED] < 0:
                b[j, POTENTIAL] = body_energy(fx, b, par, j)
            bi[j, PUSHED] = sweep
            s2 = depth * inv2 / (inv1 + inv2)
            b[j, X] -= s2 * nx
            b[j, Z] -= s2 * nz
            b[j, SHIFT_X] -= s2 * nx
            b[j, SHIFT_Z] -= s2 * nz
    return pushed


@ti.func
def impulse_pass(
    fx: ti.template(),
    b: ti.template(),
    bi: ti.template(),
    cd: ti.template(),
    cp: ti.template(),
    par: ti.template(),
    acc: ti.template(),
    ipar: ti.template(),
):
    n = ti.cast(ipar[N], ti.i32)
    for _ in range(ti.cast(ipar[PASSES], ti.i32)):
        for i in range(n):
            if ti.static(fx.wall):
                if bi[i, WALL_ON]:
                    resolve(b, par, acc, ipar, i, -1, par[WALL_X], b[i, WALL_PZ], 1.0, 0.0, b[i, WALL_GAP])
            if ti.static(fx.collisions):
                for s in range(bi[i, NCONTACT]):
                    resolve(
                        b, par, acc, ipar, i, cp[s, i], cd[s, i, CPX], cd[s, i, CPZ], cd[s, i, CNX], cd[s, i, CNZ], cd[s, i, CGAP]
                    )


@ti.func
def deep_approach(b: ti.template(), par: ti.template(), i, j, px, pz, nx, nz, gap):
    """1 if the contact still approaches so fast that it would overlap by more than
    DEEP_FRACTION of a disc radius by the end of the step."""
    rx2 = 0.0
    rz2 = 0.0
    r = b[i, RADIUS]
    if j >= 0:
        rx2 = px - b[j, X]
        rz2 = pz - b[j, Z]
        r = ti.min(r, b[j, RADIUS])
    vn = normal_speed(b, i, j, px - b[i, X], pz - b[i, Z], rx2, rz2, nx, nz)
    return ti.cast(vn < 0 and gap + par[DT] * vn < -DEEP_FRACTION * r, ti.i32)


@ti.func
def deep_contacts(
    fx: ti.template(), b: ti.template(), bi: ti.template(), cd: ti.template(), cp: ti.template(), par: ti.template(), i
):
    """How many of body i's contacts (wall, partners j > i) still approach deeply."""
    count = 0
    if ti.static(fx.wall):
        if bi[i, WALL_ON]:
            count += deep_approach(b, par, i, -1, par[WALL_X], b[i, WALL_PZ], 1.0, 0.0, b[i, WALL_GAP])
    if ti.static(fx.collisions):
        for s in range(bi[i, NCONTACT]):
            j = cp[s, i]
            count += deep_approach(b, par, i, j, cd[s, i, CPX], cd[s, i, CPZ], cd[s, i, CNX], cd[s, i, CNZ], cd[s, i, CGAP])
    return count


@ti.func
def correction_pass(
    fx: ti.template(),
    b: ti.template(),
    bi: ti.template(),
    cd: ti.template(),
    cp: ti.template(),
    par: ti.template(),
    acc: ti.template(),
    ipar: ti.template(),
):
    n = b.shape[0]
    for i in range(n):
        b[i, SHIFT_X] = 0.0
        b[i, SHIFT_Z] = 0.0
        bi[i, PUSHED] = -1  # the last sweep that moved body i
        if ti.static(fx.collisions):
            # each contact's end-of-step gap, once, before anything is pushed (stored in CGAP)
            for s in range(bi[i, NCONTACT]):
                cd[s, i, CGAP] = predicted_gap(
                    b, par, i, cp[s, i], cd[s, i, CPX], cd[s, i, CPZ], cd[s, i, CNX], cd[s, i, CNZ], cd[s, i, CGAP]
                )
    for sweep in range(MAX_CORRECT):
        pushed = 0
        # after the first sweep, only contacts of a body moved since the previous sweep
        since = sweep - 1
        for i in range(n):
            if ti.static(fx.wall):
                if bi[i, WALL_ON] and bi[i, PUSHED] >= since:
                    pushed += push(fx, b, bi, par, ipar, sweep, i, -1, 1.0, 0.0, 0.0)
            if ti.static(fx.collisions):
                for s in range(bi[i, NCONTACT]):
                    j = cp[s, i]
                    if ti.max(bi[i, PUSHED], bi[j, PUSHED]) >= since:
                        pushed += push(fx, b, bi, par, ipar, sweep, i, j, cd[s, i, CNX], cd[s, i, CNZ], cd[s, i, CGAP])
        if pushed == 0:
            break
    # the corrections' change of potential energy, per moved body, in body order
    for i in range(n):
        if bi[i, PUSHED] >= 0:
            acc[ACC_CORRECTION] -= body_energy(fx, b, par, i) - b[i, POTENTIAL]


@ti.func
def detect_all_serial(
    fx: ti.template(),
    b: ti.template(),
    bi: ti.template(),
    cd: ti.template(),
    cp: ti.template(),
    nl: ti.template(),
    nr: ti.template(),
    cells: ti.template(),
    par: ti.template(),
    ipar: ti.template(),
):
    """Phases 2-4 (reach, bin, detect) with serial loops."""
    n = b.shape[0]
    vmax = 0.0
    for i in range(n):
        vmax = ti.max(vmax, speed(b, i))
    par[SPEED_MAX] = vmax
    rmax = 0.0
    for i in range(n):
        rmax = ti.max(rmax, reach(b, par, i))
    par[REACH_MAX] = rmax
    size = cell_size(par)
    if ti.static(fx.collisions):
        ncells = ipar[NCELLS]
        for i in range(n):
            c = cell_of(b[i, X], size, ncells)
            bi[i, CELL] = c
            cells[c, COUNT] += 1
        scan_cells(cells, ncells)
        for i in range(n):
            c = bi[i, CELL]
            bi[cells[c, FILL], SORTED] = i
            cells[c, FILL] += 1
    for i in range(n):
        detect(fx, b, bi, cd, cp, nl, nr, cells, par, ipar, i, size)


@ti.func
def one_step_serial(
    fx: ti.template(),
    b: ti.template(),
    bi: ti.template(),
    cd: ti.template(),
    cp: ti.template(),
    nl: ti.template(),
    nr: ti.template(),
    cells: ti.template(),
    par: ti.template(),
    acc: ti.template(),
    ipar: ti.template(),
):
    """Phases 1-7 of one step with serial loops (COS, SIN valid on entry)."""
    n = b.shape[0]
    for i in range(n):
        kick(fx, b, par, i)
    if ti.static(fx.collisions or fx.wall):
        redetect = 1
        for _attempt in range(MAX_DETECT):
            if redetect:
                detect_all_serial(fx, b, bi, cd, cp, nl, nr, cells, par, ipar)
            impulse_pass(fx, b, bi, cd, cp, par, acc, ipar)
            grown = 0
            for i in range(n):
                grown += outran(b, par, i)
            redetect = grown
            deep = 0
            if grown == 0:
                for i in range(n):
                    deep += deep_contacts(fx, b, bi, cd, cp, par, i)
            if grown == 0 and deep == 0:
                break
    for i in range(n):
        drift(b, par, i)
    if ti.static(fx.collisions or fx.wall):
        correction_pass(fx, b, bi, cd, cp, par, acc, ipar)


# ---------------------------------------------------------------- kernels
@ti.kernel
def steps_serial(
    fx: ti.template(),
    steps: ti.i32,
    b: arr,
    bi: arr,
    cd: arr,
    cp: arr,
    nl: arr,
    nr: arr,
    cells: arr,
    par: arr,
    acc: arr,
    ipar: arr,
):
    """``steps`` whole steps in one call, every loop serial (small N: no launch costs)."""
    ti.loop_config(serialize=True)
    for _ in range(1):
        n = b.shape[0]
        for i in range(n):
            orient(b, i)  # the state may have been set from the host since the last call
        for _step in range(steps):
            one_step_serial(fx, b, bi, cd, cp, nl, nr, cells, par, acc, ipar)


@ti.kernel
def orient_all(b: arr):
    for i in range(b.shape[0]):
        orient(b, i)


@ti.kernel
def kick_all(fx: ti.template(), b: arr, par: arr):
    for i in range(b.shape[0]):
        kick(fx, b, par, i)


@ti.kernel
def speed_all(b: arr, par: arr):
    par[SPEED_MAX] = 0.0
    for i in range(b.shape[0]):
        ti.atomic_max(par[SPEED_MAX], speed(b, i))


@ti.kernel
def reach_all(b: arr, par: arr):
    par[REACH_MAX] = 0.0
    for i in range(b.shape[0]):
        ti.atomic_max(par[REACH_MAX], reach(b, par, i))


@ti.kernel
def bin_count(b: arr, bi: arr, cells: arr, par: arr, ipar: arr):
    size = cell_size(par)
    ncells = ipar[NCELLS]
    for i in range(b.shape[0]):
        c = cell_of(b[i, X], size, ncells)
        bi[i, CELL] = c
        ti.atomic_add(cells[c, COUNT], 1)


@ti.kernel
def bin_scan(cells: arr, ipar: arr):
    ti.loop_config(serialize=True)
    for _ in range(1):
        scan_cells(cells, ipar[NCELLS])


@ti.kernel
def bin_fill(bi: arr, cells: arr):
    for i in range(bi.shape[0]):
        c = bi[i, CELL]
        slot = ti.atomic_add(cells[c, FILL], 1)
        bi[slot, SORTED] = i


@ti.kernel
def detect_all(fx: ti.template(), b: arr, bi: arr, cd: arr, cp: arr, nl: arr, nr: arr, cells: arr, par: arr, ipar: arr):
    size = cell_size(par)
    for i in range(b.shape[0]):
        detect(fx, b, bi, cd, cp, nl, nr, cells, par, ipar, i, size)


@ti.kernel
def impulses(fx: ti.template(), b: arr, bi: arr, cd: arr, cp: arr, par: arr, acc: arr, ipar: arr):
    ti.loop_config(serialize=True)
    for _ in range(1):
        impulse_pass(fx, b, bi, cd, cp, par, acc, ipar)


@ti.kernel
def check_reach(fx: ti.template(), b: arr, bi: arr, cd: arr, cp: arr, par: arr, ipar: arr):
    """ipar[AGAIN]: 2 if some body outran its reach (detect again), else 1 if some contact
    still approaches deeply (another impulse pass), else 0. One parallel loop, one flag."""
    ipar[AGAIN] = 0
    for i in range(b.shape[0]):
        if outran(b, par, i):
            ti.atomic_max(ipar[AGAIN], 2)
        elif deep_contacts(fx, b, bi, cd, cp, par, i) > 0:
            ti.atomic_max(ipar[AGAIN], 1)


@ti.kernel
def drift_all(b: arr, par: arr):
    for i in range(b.shape[0]):
        drift(b, par, i)


@ti.kernel
def correct(fx: ti.template(), b: arr, bi: arr, cd: arr, cp: arr, par: arr, acc: arr, ipar: arr):
    ti.loop_config(serialize=True)
    for _ in range(1):
        correction_pass(fx, b, bi, cd, cp, par, acc, ipar)


@ti.kernel
def energies(fx: ti.template(), b: arr, par: arr):
    """Per-body kinetic and potential energy into the KINETIC and POTENTIAL columns."""
    for i in range(b.shape[0]):
        orient(b, i)
        b[i, KINETIC] = 0.5 * b[i, MASS] * (b[i, VX] ** 2 + b[i, VZ] ** 2) + 0.5 * b[i, INERTIA] * b[i, OM] ** 2
        b[i, POTENTIAL] = body_energy(fx, b, par, i)

"""The bonds' host side (numpy, no Taichi): which icebergs are bonded and where, the bond
table at t = 0, the time step's limit, and what an output event reads from the table (the
bonds' energy, the fragments). Made by the model of a scene that names the bonds
(:class:`~..base.State`)."""

from __future__ import annotations

import math

import numpy as np

from ....errors import error
from ....geometry import faces, mass_properties
from ..base import State
from . import GEOMETRY, MAX_BONDS, MIN_OVERLAP, REST, TABLE, TOUCH, Bond, weibull_scale

# ---------------------------------------------------------------- geometry at t = 0


UNKNOWN = -2.0  # NB1 / NB2 of a bond whose neighbours a [start]'s file could not tell


def shared_faces(bergs, i: np.ndarray, j: np.ndarray):
    """``(point (P, 2), normal from i to j (P, 2), length (P,), found (P,))`` of the face each
    pair of icebergs ``i[k], j[k]`` shares at t = 0: antiparallel faces at most :data:`TOUCH`
    apart that overlap by more than :data:`MIN_OVERLAP` (the longest overlap if several); the
    point is the overlap's middle, halfway between the two faces."""
    i, j = np.asarray(i, dtype=np.int64), np.asarray(j, dtype=np.int64)
    ci, ni, ti, hi = (q[:, :, None] for q in faces(bergs, i))
    cj, nj, _tj, hj = (q[:, None, :] for q in faces(bergs, j))
    f = ci.shape[1]  # faces per iceberg: a rectangle's 4, the scene's most corners
    gap = cj - ci
    anti = np.sum(ni * nj, -1) < -1.0 + 1e-6
    sep = np.sum(gap * ni, -1)
    off = np.sum(gap * ti, -1)
    lo = np.maximum(-hi, off - hj)
    up = np.minimum(hi, off + hj)
    ok = anti & (np.abs(sep) <= TOUCH) & (up - lo > MIN_OVERLAP)
    score = np.where(ok, up - lo, -np.inf).reshape(len(i), f * f)
    best = np.argmax(score, 1)  # the first of the longest, faces of i outer
    k = np.arange(len(i))
    fi, fj = best // f, best % f
    mid = 0.5 * (lo[k, fi, fj] + up[k, fi, fj])
    sep_k = sep[k, fi, fj]
    n = ni[k, fi, 0]
    point = ci[k, fi, 0] + mid[:, None] * ti[k, fi, 0] + 0.5 * sep_k[:, None] * n
    return point, n, (up - lo)[k, fi, fj], np.isfinite(score[k, best])


def shared_face(bergs, i: int, j: int):
    """``(point, normal from i to j, length)`` of the face icebergs i and j share at t = 0
    (:func:`shared_faces`), or ``None``."""
    point, n, length, found = shared_faces(bergs, np.array([i]), np.array([j]))
    return (point[0], n[0], float(length[0])) if found[0] else None


def wall_faces(bergs, i: np.ndarray, wall_x: float):
    """``(point on the wall, normal from the iceberg to the wall, length, found)`` of the face of
    each iceberg ``i`` that lies on the wall at t = 0."""
    centre, normal, _t, half = faces(bergs, np.asarray(i, dtype=np.int64))
    ok = (normal[..., 0] < -1.0 + 1e-6) & (np.abs(centre[..., 0] - wall_x) <= TOUCH) & (half > 0)
    f = np.argmax(ok, 1)
    k = np.arange(len(f))
    point = np.stack([np.full(len(f), wall_x), centre[k, f, 1]], -1)
    return point, normal[k, f], 2.0 * half[k, f], ok[k, f]


def pairs(scene, bergs) -> tuple[list[tuple[int, int]], tuple[str, object, str] | None]:
    """The bonded pairs ``(a, b)`` of the scene (``b = -1``: the wall), or the refusal
    ``(key, value, accepts)`` of a ``[[bond]]`` table that cannot bond. With cells (an
    iceberg given as ``cells = [nx, nz]``) the pairs are of cells: every two neighbours in an
    iceberg's grid, and across a bonded joint (a shelf's, a ``[[bond]]``'s, the wall's) every
    two cells that share a face there."""
    cells = bergs.parent is not None
    out = _inner_pairs(bergs) if cells else []
    sh = scene.shelf
    if sh is not None:
        if not sh.intact:  # no joints, or every joint cut through: the pieces are free
            return out, None
        pieces = int(bergs.parent.max()) + 1 if cells else bergs.count
        last = pieces - sh.front  # icebergs [0, last) are the bonded shelf
        if not cells:
            out = [(0, -1)] if sh.bonded_wall and last > 0 else []
            out += [(i, i + 1) for i in range(max(0, last - 1))]
            return out, None
        if sh.bonded_wall and last > 0:
            out += _wall_pairs(scene, bergs, 0)
        for i in range(max(0, last - 1)):
            out += _joint_pairs(bergs, i, i + 1)
        return out, None
    tables = dict(scene.tables).get("bond", ())
    icebergs = int(bergs.parent.max()) + 1 if cells else bergs.count
    seen = set()
    for k, t in enumerate(tables):
        a, b = int(t["a"]), int(t["b"])
        for key, v in (("a", a), ("b", b)):
            if v >= icebergs:
                return [], (f"bond[{k}].{key}", v, f"must be an [[iceberg]] index below {icebergs}")
        if a == b:
            return [], (f"bond[{k}].b", b, "must differ from bond.a (an iceberg is not bonded to itself)")
        p = (min(a, b), max(a, b))
        if p in seen:
            return [], (f"bond[{k}].b", b, f"icebergs {p[0]} and {p[1]} are bonded already by an earlier [[bond]]")
        seen.add(p)
        top_open, base_open = t.get("crevasse_depth", 0.0), t.get("basal_crevasse_depth", 0.0)
        if top_open + base_open >= 1.0:
            return [], (
                f"bond[{k}].basal_crevasse_depth",
                base_open,
                f"with bond[{k}].crevasse_depth = {top_open:g} the crevasses leave no ligament; the two must add up to "
                "less than 1 (a joint cut through is no bond: leave the [[bond]] out)",
            )
        joint = _joint_pairs(bergs, *p) if cells else ([p] if shared_face(bergs, *p) is not None else [])
        if not joint:
            return [], (
                f"bond[{k}].b",
                b,
                f"icebergs {p[0]} and {p[1]} share no face at t = 0 (bonded faces must face each other within "
                f"{TOUCH:g} w and overlap)",
            )
        if top_open + base_open > 0.0:
            ij = np.asarray(joint, dtype=np.int64)
            if np.all(np.abs(shared_faces(bergs, ij[:, 0], ij[:, 1])[1][:, 0]) < 1e-9):  # the faces do not rise
                key = "crevasse_depth" if top_open > 0.0 else "basal_crevasse_depth"
                return [], (
                    f"bond[{k}].{key}",
                    t.get(key),
                    f"icebergs {p[0]} and {p[1]} share a horizontal face: a crevasse opens a joint from its top or "
                    "its base, so it needs a joint that rises (side by side); leave it out",
                )
        out += joint
    return out, None


def _inner_pairs(bergs) -> list[tuple[int, int]]:
    """Every two cells of one iceberg that are neighbours in its grid (they share a face)."""
    index = {(int(p), int(ix), int(iz)): k for k, (p, (ix, iz)) in enumerate(zip(bergs.parent, bergs.cell, strict=True))}
    out = []
    for (p, ix, iz), k in index.items():
        for nb in ((p, ix + 1, iz), (p, ix, iz + 1)):
            if nb in index:
                out.append((k, index[nb]))
    return out


def _joint_pairs(bergs, a: int, b: int) -> list[tuple[int, int]]:
    """The cells of iceberg ``a`` and of ``b`` that share a face at t = 0, as pairs."""
    ca, cb = np.flatnonzero(bergs.parent == a), np.flatnonzero(bergs.parent == b)
    i, j = np.repeat(ca, cb.size), np.tile(cb, ca.size)
    found = shared_faces(bergs, i, j)[3]
    return [(int(p), int(q)) for p, q in zip(i[found], j[found], strict=True)]


def _wall_pairs(scene, bergs, a: int) -> list[tuple[int, int]]:
    """The cells of iceberg ``a`` with a face on the wall at t = 0, each bonded to it."""
    ca = np.flatnonzero(bergs.parent == a)
    found = wall_faces(bergs, ca, scene.physics.wall_x)[3]
    return [(int(k), -1) for k in ca[found]]


def build(scene, bergs, pair_list) -> np.ndarray:
    """The bond table's rows at t = 0 (f64) for ``pair_list``: the geometry, then the material.
    A bonded shelf's joints keep the intact ligament between its crevasses (:func:`joints`):
    a joint's bond is cut down to it, and a cell's bond wholly within a crevasse is not made.
    A bond cut shorter than its pair's shared face leaves the crevasse's walls beside it
    touching through contacts (``TOUCHING``: docs/bonds.md, Crevasses)."""
    joint, band, open_edge = joints(scene, bergs, pair_list)
    rows = geometry(scene.physics.wall_x, bergs, pair_list, band)
    if joint.any():
        keep = rows[: len(pair_list), Bond.LEN] > MIN_OVERLAP
        rows, joint = rows[: len(pair_list)][keep], joint[keep]
        band, open_edge = band[keep], open_edge[keep]
        if not rows.shape[0]:
            rows = geometry(scene.physics.wall_x, bergs, [])
    lines(rows, bergs, band, open_edge)
    out = material(scene, bergs, rows)
    # the kept pairs are the first rows, in order
    if joint.any() and scene.shelf is not None and scene.shelf.joint_strength != 1.0:
        out[np.flatnonzero(joint), Bond.ST] *= scene.shelf.joint_strength
        out[np.flatnonzero(joint), Bond.SS] *= scene.shelf.joint_strength
        out[np.flatnonzero(joint), Bond.GCL] *= scene.shelf.joint_strength**2  # G ~ s^2 / E' at one modulus
    return out


def joints(scene, bergs, pair_list) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Which pairs join two pieces of a bonded shelf (not a cell to its piece's cell, not the
    wall), each pair's intact band of heights ``(P, 2)`` at t = 0: at a joint, from
    ``basal_crevasse_depth`` of the joint's height above its base to ``crevasse_depth`` of it
    below its top (the joint's height: where both pieces reach); elsewhere unbounded; and
    which of the band's two edges (base, top) is a crevasse's (``(P, 2)``, bool)."""
    n = len(pair_list)
    band = np.tile([-np.inf, np.inf], (n, 1))
    joint = np.zeros(n, dtype=bool)
    open_edge = np.zeros((n, 2), dtype=bool)
    sh = scene.shelf
    if not n or (sh is not None and not sh.intact):
        return joint, band, open_edge
    pr = np.asarray(pair_list, dtype=np.int64)
    piece = bergs.parent if bergs.parent is not None else np.arange(bergs.count)
    pa, pb = piece[pr[:, 0]], np.where(pr[:, 1] >= 0, piece[np.maximum(pr[:, 1], 0)], -1)
    joint = (pr[:, 1] >= 0) & (pa != pb)
    top_open, base_open = _crevasses(scene, pa, pb)
    if sh is None:  # [[bond]] tables: a joint is one a table crevasses
        joint &= (top_open + base_open) > 0.0
    if not joint.any() or not (top_open + base_open)[joint].any():
        return joint, band, open_edge
    low, high = heights(bergs, piece)
    bottom = np.maximum(low[pa], low[np.maximum(pb, 0)])
    top = np.minimum(high[pa], high[np.maximum(pb, 0)])
    h = top - bottom
    band[joint, 0] = (bottom + base_open * h)[joint]
    band[joint, 1] = (top - top_open * h)[joint]
    open_edge[:, 0] = joint & (base_open > 0.0)
    open_edge[:, 1] = joint & (top_open > 0.0)
    return joint, band, open_edge


def _crevasses(scene, pa: np.ndarray, pb: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each pair's crevasse depths (from the top, from the base; fractions of the joint's
    height) by the pieces it joins: a shelf's at every joint, or a ``[[bond]]`` table's own."""
    sh = scene.shelf
    if sh is not None:
        return np.full(pa.size, sh.crevasse_depth), np.full(pa.size, sh.basal_crevasse_depth)
    top_open, base_open = np.zeros(pa.size), np.zeros(pa.size)
    for t in dict(scene.tables).get("bond", ()):
        a, b = int(t["a"]), int(t["b"])
        here = ((pa == a) & (pb == b)) | ((pa == b) & (pb == a))
        top_open[here] = t.get("crevasse_depth", 0.0)
        base_open[here] = t.get("basal_crevasse_depth", 0.0)
    return top_open, base_open


def heights(bergs, piece: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The lowest and highest point of each piece (the icebergs, or the ones whose cells
    ``piece`` names) at t = 0."""
    low, high = np.full(int(piece.max()) + 1, np.inf), np.full(int(piece.max()) + 1, -np.inf)
    centre, _, tangent, half = faces(bergs, np.arange(bergs.count))
    face = half > 0  # a polygon's padding has none
    rise = np.abs(tangent[..., 1]) * np.where(face, half, 0.0)
    np.minimum.at(low, piece, np.where(face, centre[..., 1] - rise, np.inf).min(1))
    np.maximum.at(high, piece, np.where(face, centre[..., 1] + rise, -np.inf).max(1))
    return low, high


def geometry(wall_x: float, bergs, pair_list, band: np.ndarray | None = None) -> np.ndarray:
    """Rows with each bond's pair and rest geometry (``GEOMETRY`` columns), intact; ``band``:
    each pair's intact heights ``(P, 2)`` (:func:`joints`), its face cut down to them (its
    point the middle of what is left; its length 0 if nothing is), and a face cut shorter
    than the pair shares marked ``TOUCHING`` (the crevasse's walls beside it touch)."""
    rows = np.zeros((max(1, len(pair_list)), TABLE.size))
    rows[:, Bond.A] = -1.0
    rows[:, Bond.B] = -1.0
    if not pair_list:
        return rows
    pr = np.asarray(pair_list, dtype=np.int64)
    i, j = pr[:, 0], pr[:, 1]
    wall = j < 0
    jj = np.where(wall, 0, j)
    point, normal, length, _ = shared_faces(bergs, i, jj)
    if wall.any():
        wp, wn, wl, _ = wall_faces(bergs, i[wall], wall_x)
        point[wall], normal[wall], length[wall] = wp, wn, wl
    touching = np.zeros(len(pair_list))
    if band is not None and np.isfinite(band).any():
        point, cut = _within(point, normal, length, band)
        touching, length = np.where(cut < length - MIN_OVERLAP, 1.0, 0.0), cut
    x = np.stack([np.asarray(bergs.x, dtype=np.float64), np.asarray(bergs.z, dtype=np.float64)], -1)
    th = np.asarray(bergs.theta, dtype=np.float64)
    xi = x[i]
    span = np.where(wall, np.abs(np.sum((point - xi) * normal, -1)), np.abs(np.sum((x[jj] - xi) * normal, -1)))

    def body_frame(vec, angle):
        c, s = np.cos(angle), np.sin(angle)
        return c * vec[:, 0] + s * vec[:, 1], -s * vec[:, 0] + c * vec[:, 1]

    n = len(pair_list)
    rows[:n, Bond.A] = i
    rows[:n, Bond.B] = j
    rows[:n, Bond.UA], rows[:n, Bond.VA] = body_frame(point - xi, th[i])
    ub, vb = body_frame(point - x[jj], th[jj])
    rows[:n, Bond.UB] = np.where(wall, point[:, 0], ub)
    rows[:n, Bond.VB] = np.where(wall, point[:, 1], vb)
    rows[:n, Bond.NU], rows[:n, Bond.NV] = body_frame(normal, th[i])
    rows[:n, Bond.DTH] = np.where(wall, -th[i], th[jj] - th[i])
    rows[:n, Bond.LEN] = length
    rows[:n, Bond.SPAN] = span
    rows[:n, Bond.TOUCHING] = touching
    rows[:n, Bond.INTACT] = 1.0
    return rows


def faces_at_start(rows: np.ndarray, bergs) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each bond's face at t = 0 in the world frame (:func:`world`): its middle, its normal,
    its length."""
    x, z, th = (np.asarray(v, dtype=np.float64) for v in (bergs.x, bergs.z, bergs.theta))
    i, _, _, ra, n, _, _ = world(rows, x, z, th)
    return np.stack([x[i] + ra[0], z[i] + ra[1]], -1), np.stack(n, -1), rows[:, Bond.LEN]


def lines(rows: np.ndarray, bergs, band: np.ndarray | None = None, open_edge: np.ndarray | None = None) -> None:
    """Set (in place) each bond's neighbours along its face's line (``NB1``, ``NB2``: the bonds
    whose faces continue it, lying on the same line and abutting it at t = 0, with the ice
    bonded across the point where they meet: a layer's next layer across one joint, a column's
    next column along one layer's face, not across a crevasse; -1: none) and whether its face
    ends at a crevasse's edge inside its joint (``TIP0``, and ``TIP`` from it): a crack's tip
    from the start (``band``, ``open_edge``: :func:`joints`)."""
    on = np.flatnonzero(rows[:, Bond.A] >= 0)
    rows[:, Bond.NB1] = rows[:, Bond.NB2] = rows[:, Bond.BR1] = rows[:, Bond.BR2] = -1.0
    rows[:, Bond.TIP0] = rows[:, Bond.TIP] = 0.0
    if not on.size:
        return
    every = faces_at_start(rows, bergs)
    point, normal, length = (v[on] for v in every)
    flip = (normal[:, 0] < -1e-12) | ((np.abs(normal[:, 0]) <= 1e-12) & (normal[:, 1] < 0.0))
    normal = np.where(flip[:, None], -normal, normal)
    along = np.stack([-normal[:, 1], normal[:, 0]], -1)
    line = _groups(np.arctan2(normal[:, 1], normal[:, 0]), 1e-9)  # one direction, then one line of it
    line = _groups(np.sum(point * normal, -1), MIN_OVERLAP, line)
    u = np.sum(point * along, -1)
    order = np.lexsort((u, line))
    same = line[order][1:] == line[order][:-1]
    gap = u[order][1:] - u[order][:-1] - 0.5 * (length[order][1:] + length[order][:-1])
    lo, hi = on[order][:-1], on[order][1:]  # lo's face ends where hi's begins
    keep = same & (np.abs(gap) < MIN_OVERLAP)
    ends = order[:-1][keep]  # lo's place in point, normal, length
    meet = point[ends] + along[ends] * (0.5 * length[ends])[:, None]
    bridge = np.full(lo.size, -1, dtype=np.int64)
    bridge[keep] = _bonded_across(rows, lo[keep], hi[keep], meet, every)
    keep &= bridge >= 0
    rows[lo[keep], Bond.NB2], rows[lo[keep], Bond.BR2] = hi[keep], bridge[keep]
    rows[hi[keep], Bond.NB1], rows[hi[keep], Bond.BR1] = lo[keep], bridge[keep]
    if band is None or open_edge is None or not open_edge.any():
        return
    rise = 0.5 * length * np.abs(along[:, 1])
    top, bottom = point[:, 1] + rise, point[:, 1] - rise
    b, o = band[on], open_edge[on]
    tip = (o[:, 1] & (np.abs(top - b[:, 1]) < MIN_OVERLAP)) | (o[:, 0] & (np.abs(bottom - b[:, 0]) < MIN_OVERLAP))
    rows[on, Bond.TIP0] = rows[on, Bond.TIP] = np.where(tip, 1.0, 0.0)


def _groups(value: np.ndarray, tol: float, within: np.ndarray | None = None) -> np.ndarray:
    """Group labels of ``value`` (within the groups ``within``, if given): sorted, a new group
    wherever the next differs by more than ``tol`` (so no rounding splits a group at a digit)."""
    within = np.zeros(value.size, dtype=np.int64) if within is None else within
    order = np.lexsort((value, within))
    new = np.ones(value.size, dtype=bool)
    new[1:] = (within[order][1:] != within[order][:-1]) | (np.diff(value[order]) > tol)
    label = np.empty(value.size, dtype=np.int64)
    label[order] = np.cumsum(new)
    return label


def _bonded_across(rows: np.ndarray, r1: np.ndarray, r2: np.ndarray, meet: np.ndarray, faces: tuple) -> np.ndarray:
    """The bond that makes the ice whole where the faces of bonds ``r1`` and ``r2`` meet (at
    ``meet``, ``(P, 2)``), or -1: a bond at t = 0 that joins an iceberg of one to an iceberg
    of the other (the wall aside) and whose face reaches that point, so no crevasse lies
    between them (the bridge a crack crosses from one to the other). ``faces``: every row's
    :func:`faces_at_start`."""
    point, normal, length = faces
    ends = rows[:, [Bond.A, Bond.B]].astype(np.int64)
    n = int(ends.max()) + 2
    real = np.flatnonzero((ends[:, 0] >= 0) & (ends[:, 1] >= 0))
    code = np.concatenate([ends[real, 0] * n + ends[real, 1], ends[real, 1] * n + ends[real, 0]])
    row = np.concatenate([real, real])
    order = np.argsort(code, kind="stable")
    code, row = code[order], row[order]
    out = np.full(r1.size, -1, dtype=np.int64)
    if not code.size:  # no two icebergs bonded: nothing to bridge
        return out
    for i in (0, 1):
        for j in (0, 1):
            a, b = ends[r1, i], ends[r2, j]
            want = a * n + b
            at = np.minimum(np.searchsorted(code, want), code.size - 1)
            found = (a >= 0) & (b >= 0) & (code[at] == want)
            k = row[at]
            d = meet - point[k]
            along = np.stack([-normal[k, 1], normal[k, 0]], -1)
            on_face = (np.abs(np.sum(d * normal[k], -1)) < MIN_OVERLAP) & (
                np.abs(np.sum(d * along, -1)) <= 0.5 * length[k] + MIN_OVERLAP
            )
            out = np.where((out < 0) & found & on_face, k, out)
    return out


def _within(point: np.ndarray, normal: np.ndarray, length: np.ndarray, band: np.ndarray):
    """Each face (its middle ``point``, ``normal``, ``length``) cut down to the heights
    ``band``: the new middle and length (0: nothing left). A face that does not rise
    (horizontal) is kept whole or dropped by its height."""
    tangent = np.stack([-normal[:, 1], normal[:, 0]], -1)
    half = 0.5 * length
    rise = tangent[:, 1]
    flat = np.abs(rise) < 1e-12
    with np.errstate(divide="ignore", invalid="ignore"):
        a = (band[:, 0] - point[:, 1]) / rise
        b = (band[:, 1] - point[:, 1]) / rise
    lo = np.maximum(-half, np.where(flat, -np.inf, np.minimum(a, b)))
    hi = np.minimum(half, np.where(flat, np.inf, np.maximum(a, b)))
    inside = ~flat | ((point[:, 1] >= band[:, 0]) & (point[:, 1] <= band[:, 1]))
    keep = inside & (hi - lo > MIN_OVERLAP)
    mid = np.where(keep, 0.5 * (lo + hi), 0.0)
    return point + mid[:, None] * tangent, np.where(keep, hi - lo, 0.0)


def material(scene, bergs, rows: np.ndarray) -> np.ndarray:
    """``rows`` with each bond's stiffness, dashpot and strength from the scene's keys (the
    Weibull spread drawn from ``time.seed``'s own stream, in bond order)."""
    p = scene.physics
    on = rows[:, Bond.A] >= 0
    i = rows[on, Bond.A].astype(np.int64)
    j = rows[on, Bond.B].astype(np.int64)
    wall = j < 0
    jj = np.where(wall, 0, j)
    mass, inertia, _ = mass_properties(bergs, p.density_ratio)
    m_eff = np.where(wall, mass[i], mass[i] * mass[jj] / (mass[i] + mass[jj]))
    i_eff = np.where(wall, inertia[i], inertia[i] * inertia[jj] / (inertia[i] + inertia[jj]))
    e, nu = p.bond_modulus, p.poisson_ratio
    e_strain = e / (1.0 - nu * nu)  # plane strain: the shelf is long across the section
    g = e / (2.0 * (1.0 + nu))
    length, span = rows[on, Bond.LEN], rows[on, Bond.SPAN]
    kn, ks, kb = e_strain * length / span, g * length / span, e_strain * length**3 / (12.0 * span)
    strength = np.ones(int(on.sum()))
    if p.strength_modulus > 0 and strength.size:
        rng = np.random.default_rng((scene.time.seed, 31))  # its own stream: the tilts keep theirs
        strength = weibull_scale(p.strength_modulus) * rng.weibull(p.strength_modulus, strength.size)
        if p.strength_size > 0:  # weakest link: a bond of face l holds what l_ref does, scaled
            strength = strength * (length / p.strength_size) ** (-1.0 / p.strength_modulus)
    zeta = p.bond_damping
    out = rows.copy()
    out[on, Bond.KN], out[on, Bond.KS], out[on, Bond.KB] = kn, ks, kb
    out[on, Bond.CN] = 2.0 * zeta * np.sqrt(kn * m_eff)
    out[on, Bond.CS] = 2.0 * zeta * np.sqrt(ks * m_eff)
    out[on, Bond.CB] = 2.0 * zeta * np.sqrt(kb * i_eff)
    out[on, Bond.ST] = p.tensile_strength * strength
    out[on, Bond.SS] = p.shear_strength * strength
    out[on, Bond.GCL] = p.fracture_energy * length
    return out


def slots(n: int, table: np.ndarray) -> tuple[np.ndarray, int | None]:
    """Each iceberg's bond rows plus 1 (``(n, MAX_BONDS)``, 0: none; in bond order), and an
    iceberg with more than :data:`MAX_BONDS` bonds, if any."""
    rows = np.flatnonzero(table[:, Bond.A] >= 0)
    ends = np.concatenate([table[rows, Bond.A], table[rows, Bond.B]]).astype(np.int64)
    bond = np.concatenate([rows, rows])
    keep = ends >= 0
    ends, bond = ends[keep], bond[keep]
    order = np.lexsort((bond, ends))
    ends, bond = ends[order], bond[order]
    first = np.searchsorted(ends, ends, side="left")
    rank = np.arange(ends.size) - first
    out = np.zeros((n, MAX_BONDS))
    crowded = rank >= MAX_BONDS
    if crowded.any():
        return out, int(ends[np.argmax(crowded)])
    out[ends, rank] = bond + 1
    return out, None


def omega_max(table: np.ndarray, bergs, density_ratio: float) -> float:
    """Gershgorin's bound on the bond network's highest angular frequency at t = 0: the
    square root of the largest row sum of ``|M^-1/2 K M^-1/2|``, ``K`` the bonds' stiffness
    (the linearised springs ``k_n, k_s, k_b`` on the relative motion of each bond's two
    points), ``M`` the icebergs' masses and moments of inertia."""
    return math.sqrt(gershgorin(table, bergs, density_ratio, (Bond.KN, Bond.KS, Bond.KB)))


def gamma_max(table: np.ndarray, bergs, density_ratio: float) -> float:
    """Gershgorin's bound on the largest eigenvalue of ``M^-1/2 C M^-1/2``, ``C`` the bonds'
    dashpots (as :func:`omega_max`, with ``c_n, c_s, c_b``)."""
    return gershgorin(table, bergs, density_ratio, (Bond.CN, Bond.CS, Bond.CB))


def world(t: np.ndarray, x: np.ndarray, z: np.ndarray, th: np.ndarray):
    """Bond rows ``t`` in the world frame of the state ``x, z, th`` (numpy, f64), as the
    kernels' :func:`.kernels.points`: ``(i, jj, wall, ra, n, rb, pb)``, A's and B's indices
    (``jj`` 0 where B is the wall), which are the wall's, A's arm, the bond's normal, B's arm
    (0 for the wall) and B's point (the wall's fixed point), each vector as an (x, z) pair."""
    i = t[:, Bond.A].astype(np.int64)
    j = t[:, Bond.B].astype(np.int64)
    wall = j < 0
    jj = np.where(wall, 0, j)
    ca, sa, cb, sb = np.cos(th[i]), np.sin(th[i]), np.cos(th[jj]), np.sin(th[jj])
    ra = (ca * t[:, Bond.UA] - sa * t[:, Bond.VA], sa * t[:, Bond.UA] + ca * t[:, Bond.VA])
    n = (ca * t[:, Bond.NU] - sa * t[:, Bond.NV], sa * t[:, Bond.NU] + ca * t[:, Bond.NV])
    rb = (cb * t[:, Bond.UB] - sb * t[:, Bond.VB], sb * t[:, Bond.UB] + cb * t[:, Bond.VB])
    rb = (np.where(wall, 0.0, rb[0]), np.where(wall, 0.0, rb[1]))
    pb = (np.where(wall, t[:, Bond.UB], x[jj] + rb[0]), np.where(wall, t[:, Bond.VB], z[jj] + rb[1]))
    return i, jj, wall, ra, n, rb, pb


def gershgorin(table: np.ndarray, bergs, density_ratio: float, cols: tuple[int, int, int]) -> float:
    """The largest row sum of ``|M^-1/2 J^T diag(cols) J M^-1/2|`` over the intact bonds."""
    on = (table[:, Bond.A] >= 0) & (table[:, Bond.INTACT] > 0.5)
    if not on.any():
        return 0.0
    t = table[on]
    mass, inertia, _ = mass_properties(bergs, density_ratio)
    diag = np.stack([mass, mass, inertia], 1).reshape(-1)
    at = np.zeros(len(mass))  # the arms and the normal do not depend on where the bodies are
    i, jj, wall, ra, n, rb, _ = world(t, at, at, np.asarray(bergs.theta, dtype=np.float64))
    ra, n, rb = (np.stack(v, -1) for v in (ra, n, rb))
    sv = np.stack([-n[:, 1], n[:, 0]], -1)
    # d(d_n, d_s, dth) / d(x_A, z_A, th_A, x_B, z_B, th_B), (P, 3, 6); a wall is no body
    jac = np.zeros((len(t), 3, 6))
    for q, vec in enumerate((n, sv)):
        jac[:, q, 0:2] = -vec
        jac[:, q, 2] = -(vec[:, 1] * ra[:, 0] - vec[:, 0] * ra[:, 1])
        jac[:, q, 3:5] = vec
        jac[:, q, 5] = vec[:, 1] * rb[:, 0] - vec[:, 0] * rb[:, 1]
    jac[:, 2, 2] = -1.0
    jac[:, 2, 5] = 1.0
    jac[wall, :, 3:] = 0.0
    k = np.einsum("pai,pa,paj->pij", jac, t[:, list(cols)], jac)
    dofs = np.concatenate([3 * i[:, None] + np.arange(3), 3 * jj[:, None] + np.arange(3)], 1)
    scale = np.sqrt(diag[dofs])
    contrib = np.abs(k / (scale[:, :, None] * scale[:, None, :])).sum(2)
    contrib[wall, 3:] = 0.0
    rows = np.zeros(diag.size)
    np.add.at(rows, dofs.reshape(-1), contrib.reshape(-1))
    return float(rows.max())


def dt_limit(omega: float, gamma: float) -> float:
    """The largest stable step of the kick-drift integrator with an explicit dashpot for a
    network whose stiffness and damping (mass-weighted) are bounded by ``omega^2`` and
    ``gamma`` (:func:`omega_max`, :func:`gamma_max`): ``(sqrt(gamma^2 + 4 omega^2) - gamma) /
    omega^2``, which for one oscillator (``gamma = 2 zeta omega``) is ``2 (sqrt(1 + zeta^2) -
    zeta) / omega``; ``inf`` without bonds."""
    if omega <= 0:
        return math.inf
    return (math.sqrt(gamma * gamma + 4.0 * omega * omega) - gamma) / (omega * omega)


def check_start(scene, bergs) -> tuple[str, object, str] | None:
    """The refusal ``(key, value, accepts)`` of a scene whose bonds cannot be made, or whose
    ``time.dt`` is above the bonds' stable limit (unless ``time.allow_unstable``)."""
    pair_list, bad = pairs(scene, bergs) if scene.start is None else (_start_pairs(scene, bergs), None)
    if bad is not None:
        return bad
    if scene.start is not None and scene.physics.fracture_energy > 0.0:
        got = _read_start(scene)
        rest = None if got is None else got["rest"]
        if rest is not None and (rest.shape[1] <= REST.index("BR2") or np.any(rest[:, REST.index("NB1")] == UNKNOWN)):
            return (
                "physics.fracture_energy",
                scene.physics.fracture_energy,
                "must be 0 with a [start] from a run file written before the bonds kept their neighbours, or from a "
                "run that started from one (it cannot tell a crack's tips); start from the scene itself, or without "
                "fracture_energy",
            )
    table = build(scene, bergs, pair_list) if scene.start is None else _start_table(scene, bergs)
    _, crowded = slots(bergs.count, table)
    if crowded is not None and bergs.parent is not None and scene.start is None:  # cells whose layers do not meet
        p = int(bergs.parent[crowded])
        if scene.shelf is not None:
            key, value = "shelf.cells", scene.shelf.cells
        else:
            key, value = f"iceberg[{p}].cells", scene.iceberg_table[p].get("cells", [1, 1])
        return (
            key,
            value,
            f"gives a cell of iceberg {p} more than {MAX_BONDS} bonds: its layers meet more than one cell across a "
            "joint (pieces of different thickness, or cells of different counts either side); use one layer (nz = 1) "
            "or pieces of equal thickness and cells",
        )
    if crowded is not None:
        # the [[bond]] table that gives the iceberg one bond too many (a shelf has at most 2)
        seen = 0
        for k, t in enumerate(dict(scene.tables).get("bond", ())):
            if crowded in (t["a"], t["b"]):
                seen += 1
                if seen > MAX_BONDS:
                    key = "a" if t["a"] == crowded else "b"
                    return (
                        f"bond[{k}].{key}",
                        crowded,
                        f"bonds iceberg {crowded} a fifth time; an iceberg has at most {MAX_BONDS}",
                    )
        return ("scene.effects", "bonds", f"iceberg {crowded} has more than {MAX_BONDS} bonds")
    r = scene.physics.density_ratio
    omega, gamma = omega_max(table, bergs, r), gamma_max(table, bergs, r)
    limit = dt_limit(omega, gamma)
    dt = scene.time.dt
    n = scene.physics.bond_substeps
    if dt / n > limit and not scene.time.allow_unstable:
        digits = 10 ** (math.floor(math.log10(n * limit)) - 2)  # three digits of the largest step, rounded down
        need = math.ceil(dt / limit)
        split = f"over physics.bond_substeps = {n}, " if n > 1 else ""
        return (
            "time.dt",
            dt,
            f"{split}above the bonds' stable limit {limit:.4g} (their stiffest mode bounded by omega_max = "
            f"{omega:.4g}, their dashpots by {gamma:.4g}; physics.bond_modulus = {scene.physics.bond_modulus:g}); "
            f"use time.dt <= {math.floor(n * limit / digits) * digits:.3g}, physics.bond_substeps >= {need}, a smaller "
            "bond_modulus, or time.allow_unstable = true",
        )
    return None


# ---------------------------------------------------------------- a [start] from a bonded run


def _read_start(scene):
    got = scene.start_group("bonds")  # read by the scene, which stands above the run files
    if got is None:
        return None
    group, times = got
    return {k: group[k] for k in ("rest", "break_time")} | {"times": times}


def _start_table(scene, bergs) -> np.ndarray:
    """The bonds of the run a ``[start]`` begins from, those intact at its time, with their
    rest geometry (a bond stays at rest in the state it formed in) and the material of the
    scene's own keys."""
    got = _read_start(scene)
    if got is None:
        return build(scene, bergs, [])
    # intact in the snapshot the state is taken from (the last at or before start.time): a
    # bond that broke at t broke at the start of the step after the state at t
    t = float(scene.start.time)
    times = got["times"]
    k = int(np.searchsorted(times, t + 1e-9 * max(1.0, abs(t)), side="right")) - 1
    ts = float(times[max(k, 0)]) if times.size else 0.0
    bt = got["break_time"]
    keep = np.isnan(bt) | (bt > ts - 1e-9 * max(1.0, abs(ts)))
    rest = got["rest"][keep]
    rows = np.zeros((max(1, rest.shape[0]), TABLE.size))
    rows[:, Bond.A] = -1.0
    rows[:, Bond.B] = -1.0
    for q, name in enumerate(GEOMETRY):
        rows[: rest.shape[0], getattr(Bond, name)] = rest[:, q]
    written = REST[: rest.shape[1]]  # a file written before a column was kept has the ones before it
    if "TOUCHING" in written:  # before it, no walls touched
        rows[: rest.shape[0], Bond.TOUCHING] = rest[:, REST.index("TOUCHING")]
    # a file written before the neighbours were kept cannot tell them: UNKNOWN, kept so (a later [start] from
    # this run's file is refused a fracture energy as the file itself is); the kernels read only rows >= 0
    rows[:, Bond.NB1] = rows[:, Bond.NB2] = rows[:, Bond.BR1] = rows[:, Bond.BR2] = UNKNOWN
    if "BR2" in written:  # the neighbours kept, renumbered; one broken by then, its bridge whole, makes a tip
        new = np.cumsum(keep) - 1
        tip = rest[:, REST.index("TIP0")].copy()
        for name, via in (("NB1", "BR1"), ("NB2", "BR2")):
            nb = got["rest"][keep, REST.index(name)].astype(np.int64)
            br = got["rest"][keep, REST.index(via)].astype(np.int64)
            held = (nb >= 0) & (br >= 0)  # (UNKNOWN stays unknown)
            whole = held.copy()
            whole[held] = keep[br[held]]  # the ice between them still bonded: else the link is gone
            alive = whole.copy()
            alive[whole] = keep[nb[whole]]
            unknown = nb == UNKNOWN
            rows[: rest.shape[0], getattr(Bond, name)] = np.where(alive, new[np.maximum(nb, 0)], np.where(unknown, UNKNOWN, -1))
            rows[: rest.shape[0], getattr(Bond, via)] = np.where(alive, new[np.maximum(br, 0)], np.where(unknown, UNKNOWN, -1))
            tip = np.where(whole & ~alive, 1.0, tip)
        rows[: rest.shape[0], Bond.TIP0] = rest[:, REST.index("TIP0")]
        rows[: rest.shape[0], Bond.TIP] = tip
    rows[: rest.shape[0], Bond.INTACT] = 1.0
    return material(scene, bergs, rows)


def _start_pairs(scene, bergs) -> list:
    t = _start_table(scene, bergs)
    return [(int(a), int(b)) for a, b in t[:, [Bond.A, Bond.B]] if a >= 0]


# ---------------------------------------------------------------- fragments


def fragments(n: int, table: np.ndarray) -> np.ndarray:
    """Each iceberg's fragment label: the lowest iceberg index of its connected component
    over the intact bonds (``scipy.sparse.csgraph``; the wall joins nothing)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    on = (table[:, Bond.INTACT] > 0.5) & (table[:, Bond.A] >= 0) & (table[:, Bond.B] >= 0)
    a = table[on, Bond.A].astype(np.int64)
    b = table[on, Bond.B].astype(np.int64)
    graph = coo_matrix((np.ones(a.size), (a, b)), shape=(n, n))
    _, comp = connected_components(graph, directed=False)
    lowest = np.full(comp.max() + 1 if n else 0, n, dtype=np.int64)
    np.minimum.at(lowest, comp, np.arange(n))
    return lowest[comp]


def bond_energy(table: np.ndarray, bodies: dict, dt: float = 0.0) -> float:
    """Elastic energy of the intact bonds in the state ``bodies`` (``x, z, theta``, and with
    ``dt > 0`` ``vx, vz, omega``), summed in f64: ``U`` of the kernel's formula
    (:func:`.kernels.update`), and with ``dt``, ``U - dt/2 dU/dt``, the energy the kick-drift
    step conserves for a linear spring (it tends to ``U`` as ``dt -> 0``)."""
    t = table.astype(np.float64)
    on = (t[:, Bond.INTACT] > 0.5) & (t[:, Bond.A] >= 0)
    if not np.any(on):
        return 0.0
    t = t[on]
    x, z, th = (np.asarray(bodies[k], dtype=np.float64) for k in ("x", "z", "theta"))
    i, jj, wall, (rax, raz), (nx, nz), (rbx, rbz), (pbx, pbz) = world(t, x, z, th)
    thb = np.where(wall, 0.0, th[jj])
    dx = pbx - (x[i] + rax)
    dz = pbz - (z[i] + raz)
    dn = dx * nx + dz * nz
    ds = -dx * nz + dz * nx
    dth = thb - th[i] - t[:, Bond.DTH]
    fn, fs, m = t[:, Bond.KN] * dn, t[:, Bond.KS] * ds, t[:, Bond.KB] * dth
    u = 0.5 * (fn * dn + fs * ds + m * dth)
    if dt == 0.0:
        return float(np.sum(u))
    # - dU/dt: the power of the bond's forces on the two bodies (the kernel's G, torques)
    vx, vz, om = (np.asarray(bodies[k], dtype=np.float64) for k in ("vx", "vz", "omega"))
    sx, sz = -nz, nx
    gx, gz = fn * nx + fs * sx, fn * nz + fs * sz
    ta = rax * gz - raz * gx - (t[:, Bond.KN] - t[:, Bond.KS]) * dn * ds + m
    tb = np.where(wall, 0.0, -(rbx * gz - rbz * gx) - m)
    vbx, vbz, omb = (np.where(wall, 0.0, q[jj]) for q in (vx, vz, om))
    work = gx * (vx[i] - vbx) + gz * (vz[i] - vbz) + ta * om[i] + tb * omb
    return float(np.sum(u + 0.5 * dt * work))


class BondState(State):
    """The bonds of one model: the table's rows (one per bond, at least one) and the
    icebergs' slots."""

    def __init__(self, scene, np_real):
        self.scene = scene
        self.np_real = np_real
        bergs = scene.icebergs()
        self.n = bergs.count
        if scene.start is not None:
            self.table0 = _start_table(scene, bergs)
        else:
            pair_list, bad = pairs(scene, bergs)
            if bad is not None:  # the scene's check refuses it first; a scene built around it
                raise error(*bad)
            self.table0 = build(scene, bergs, pair_list)
        self.count = int(np.sum(self.table0[:, Bond.A] >= 0))
        self.rows = self.table0.shape[0]
        self.dt = scene.time.dt
        self.substeps = scene.physics.bond_substeps

    def initial(self) -> np.ndarray:
        return self.table0.astype(self.np_real)

    def bodies(self, rows: np.ndarray) -> None:
        s, _ = slots(self.n, self.table0)
        from ...data.schema import Body

        for k in range(MAX_BONDS):  # a bond's row plus 1 in the owners' table (0: none)
            rows[:, Body.BOND_1 + k] = np.where(s[:, k] > 0, s[:, k] + self.first_row, 0.0)

    def dims(self) -> dict[str, int]:
        return {"bond": self.count, "bond_rest": len(REST)}

    def constants(self) -> dict[str, np.ndarray]:
        t = self.table0[: self.count]
        return {
            "bonds/a": t[:, Bond.A].astype(np.int64),
            "bonds/b": t[:, Bond.B].astype(np.int64),
            "bonds/rest": np.stack([t[:, getattr(Bond, name)] for name in REST], 1),
        }

    def sample(self, rows_: np.ndarray, bodies: dict) -> dict:
        t = np.asarray(rows_, dtype=np.float64)
        on = t[: self.count, Bond.INTACT] > 0.5
        broken = ~on
        nan = np.full(self.count, np.nan)
        label = fragments(self.n, t)
        return {
            "bond_energy": np.array(bond_energy(t, bodies, self.dt / self.substeps)),  # as the (sub-)step keeps it
            "bond_energy_at_step": np.array(bond_energy(t, bodies)),  # the diagnostic's: U at the positions
            "bonds_intact": np.array(float(np.sum(on))),
            "fragments": np.array(float(np.unique(label).size)),
            "fragment": label,
            "break_time": np.where(broken, t[: self.count, Bond.AGE] * self.dt, nan),
            "break_stress": np.where(broken, t[: self.count, Bond.BREAK_SIG], nan),
            "break_shear": np.where(broken, t[: self.count, Bond.BREAK_TAU], nan),
            "peak_stress": t[: self.count, Bond.PEAK_SIG].copy(),
            "peak_shear": t[: self.count, Bond.PEAK_TAU].copy(),
        }

"""Reference geometry in numpy: the collision discs and the hydrostatics of a rectangle.

Independent of the Taichi kernels (:mod:`melange_ti.physics`), and shared by the renderer,
the pymunk peer (:mod:`melange_ti.bench.peers`) and the tests, which compare the kernels
against these formulas. Units: widths, g = rho_w = 1 (docs/model.md).
"""

from __future__ import annotations

import functools
import math

import numpy as np


def mass_inertia(width, thickness, density_ratio: float):
    """Mass ``density_ratio * width * thickness`` and moment of inertia about the centre of
    mass, ``mass (width^2 + thickness^2) / 12``, of rectangles (rho_w = 1)."""
    mass = density_ratio * width * thickness
    return mass, mass * (width**2 + thickness**2) / 12.0


def mass_properties(bergs, density_ratio: float, outlines: list[dict] | None = None):
    """Each iceberg's mass, moment of inertia about its centre of mass and bounding radius,
    arrays (N,), of :class:`melange_ti.scene.initial.Icebergs` ``bergs``: rectangles' from
    their width and thickness (:func:`mass_inertia`, the arithmetic every rectangle run was
    made with), polygons' from their corners (:func:`outline`; ``outlines``: theirs if the
    caller has them already)."""
    if bergs.outline is None:
        mass, inertia = mass_inertia(bergs.width, bergs.thickness, density_ratio)
        return mass, inertia, 0.5 * np.hypot(bergs.width, bergs.thickness)
    outlines = bergs.outlines(density_ratio) if outlines is None else outlines
    return tuple(np.array([o[k] for o in outlines]) for k in ("mass", "inertia", "bound"))


def faces(bergs, idx: np.ndarray):
    """The faces of icebergs ``idx`` of ``bergs`` in the world at their initial pose: centres,
    outward unit normals and unit tangents ``(P, F, 2)`` and half lengths ``(P, F)``. A
    rectangle's four in the order +u, -u, +v, -v (all rectangles: ``F = 4``); a polygon's
    edges, edge ``k`` from corner ``k`` to the next (counter-clockwise, so the outward normal is
    the tangent turned clockwise), half length -1 past its count (no face)."""
    idx = np.asarray(idx, dtype=np.int64)
    th = np.asarray(bergs.theta, dtype=np.float64)[idx]
    c, s = np.cos(th), np.sin(th)
    u = np.stack([c, s], -1)
    v = np.stack([-s, c], -1)
    ctr = np.stack([np.asarray(bergs.x, dtype=np.float64)[idx], np.asarray(bergs.z, dtype=np.float64)[idx]], -1)
    if bergs.outline is None:
        hw = 0.5 * np.asarray(bergs.width, dtype=np.float64)[idx]
        hh = 0.5 * np.asarray(bergs.thickness, dtype=np.float64)[idx]
        centre = np.stack([ctr + hw[:, None] * u, ctr - hw[:, None] * u, ctr + hh[:, None] * v, ctr - hh[:, None] * v], 1)
        normal = np.stack([u, -u, v, -v], 1)
        tangent = np.stack([v, v, u, u], 1)
        half = np.stack([hh, hh, hw, hw], 1)
        return centre, normal, tangent, half
    corners = np.asarray(bergs.outline, dtype=np.float64)[idx]  # (P, V, 2), body frame
    count = np.asarray(bergs.corners, dtype=np.int64)[idx]
    k = np.arange(corners.shape[1])[None, :]
    there = k < count[:, None]
    nxt = np.where(k + 1 < count[:, None], k + 1, 0)
    a = corners
    b = np.take_along_axis(corners, nxt[..., None], 1)
    length = np.hypot(*(b - a).transpose(2, 0, 1))
    t_body = (b - a) / np.where(there, length, 1.0)[..., None]
    mid = 0.5 * (a + b)

    def world(q):  # body-frame vectors (P, F, 2) turned by each iceberg's theta
        return q[..., :1] * u[:, None, :] + q[..., 1:] * v[:, None, :]

    tangent = world(t_body)
    normal = np.stack([tangent[..., 1], -tangent[..., 0]], -1)
    centre = ctr[:, None, :] + world(mid)
    half = np.where(there, 0.5 * length, -1.0)
    return centre, normal, tangent, half


def disc_radius(width, thickness, discs: int, spacing: float = 2.0):
    """Radius of the collision discs of rectangles ``width`` x ``thickness``.

    ``k = discs/4`` discs per face have their centres on the rectangle inset by the radius
    ``r`` (so the union is tangent to the true faces); on the longest face ``L`` they are
    ``(L - 2r)/k`` apart. Setting that spacing to ``spacing * r`` gives
    ``r = L / (k spacing + 2)``. ``spacing = 2`` (the default) is the paper's no-hole limit
    ``l/(n_d/4 + 1) = 2 r_d``; smaller values overlap the discs more (smoother faces,
    rounder corners). The radius may not exceed half the shortest face.
    """
    longest = np.maximum(width, thickness)
    return longest / ((discs // 4) * spacing + 2.0)


def disc_local(width, thickness, discs: int, spacing: float = 2.0) -> tuple[np.ndarray, np.ndarray]:
    """Body-frame disc centres (N, discs, 2) and radii (N,), as ``physics.shape.discs.disc_local``.

    ``k = discs/4`` discs per face; face ``f`` starts at a corner of the rectangle inset by
    the radius and takes ``k`` equal steps towards the next inset corner.
    """
    width = np.atleast_1d(np.asarray(width, dtype=float))
    thickness = np.atleast_1d(np.asarray(thickness, dtype=float))
    r = np.asarray(disc_radius(width, thickness, discs, spacing), dtype=float)
    k = discs // 4
    a = np.arange(discs)
    f = a // k
    t = (a % k) / k
    iu = (0.5 * width - r)[:, None]
    iv = (0.5 * thickness - r)[:, None]
    u = np.select([f == 0, f == 1, f == 2], [iu + 0 * t, iu - 2 * iu * t, -iu + 0 * t], -iu + 2 * iu * t)
    v = np.select([f == 0, f == 1, f == 2], [-iv + 2 * iv * t, iv + 0 * t, iv - 2 * iv * t], -iv + 0 * t)
    return np.stack([u, v], axis=-1), r


# ---------------------------------------------------------------- hydrostatics
# Corners of the rectangle, counter-clockwise from the lower right in the body frame
# (same order as melange_ti.physics.shape.hydrostatics.corner).
_SU = np.array([1.0, 1.0, -1.0, -1.0])
_SV = np.array([-1.0, 1.0, 1.0, -1.0])


def _segment(px, pz, qx, qz):
    cross = px * qz - qx * pz
    return 0.5 * cross, cross * (px + qx) / 6.0, cross * (pz + qz) / 6.0


def submerged_moments(z, theta, half_width, half_thickness, water_level=0.0):
    """Area ``A`` and first moments ``Sx, Sz`` (about the centre) of the submerged part.

    Vectorised over icebergs (arrays of shape (N,)); exact clipping of the rectangle at the
    flat water line. The buoyancy force is ``(0, A)`` and its torque about the centre ``Sx``
    (units g = rho_water = 1).
    """
    z = np.asarray(z, dtype=np.float64)
    theta = np.asarray(theta, dtype=np.float64)
    hw = np.broadcast_to(np.asarray(half_width, dtype=np.float64), z.shape)
    hh = np.broadcast_to(np.asarray(half_thickness, dtype=np.float64), z.shape)
    c, s = np.cos(theta), np.sin(theta)
    level = water_level - z
    # corners relative to the centre, shape (4, N)
    cx = _SU[:, None] * hw * c - _SV[:, None] * hh * s
    cz = _SU[:, None] * hw * s + _SV[:, None] * hh * c
    area = np.zeros_like(z)
    sx = np.zeros_like(z)
    sz = np.zeros_like(z)
    exit_x = np.zeros_like(z)
    entry_x = np.zeros_like(z)
    for k in range(4):
        px, pz = cx[k], cz[k]
        qx, qz = cx[(k + 1) % 4], cz[(k + 1) % 4]
        p_wet = pz < level
        q_wet = qz < level
        both = p_wet & q_wet
        cut = p_wet != q_wet
        with np.errstate(divide="ignore", invalid="ignore"):
            t = np.where(cut, (level - pz) / np.where(cut, qz - pz, 1.0), 0.0)
        mx = px + t * (qx - px)
        # fully wet edge
        a, b, d = _segment(px, pz, qx, qz)
        # p wet, q dry: p -> cut (the boundary leaves the water)
        a1, b1, d1 = _segment(px, pz, mx, level)
        # p dry, q wet: cut -> q (the boundary enters the water)
        a2, b2, d2 = _segment(mx, level, qx, qz)
        leaving = cut & p_wet
        entering = cut & q_wet
        area += np.where(both, a, 0.0) + np.where(leaving, a1, 0.0) + np.where(entering, a2, 0.0)
        sx += np.where(both, b, 0.0) + np.where(leaving, b1, 0.0) + np.where(entering, b2, 0.0)
        sz += np.where(both, d, 0.0) + np.where(leaving, d1, 0.0) + np.where(entering, d2, 0.0)
        exit_x = np.where(leaving, mx, exit_x)
        entry_x = np.where(entering, mx, entry_x)
    crossed = np.zeros(z.shape, dtype=bool)
    for k in range(4):
        crossed |= (cz[k] < level) != (cz[(k + 1) % 4] < level)
    a, b, d = _segment(exit_x, level, entry_x, level)
    area += np.where(crossed, a, 0.0)
    sx += np.where(crossed, b, 0.0)
    sz += np.where(crossed, d, 0.0)
    return area, sx, sz


def potential_energy(z, theta, width, thickness, density_ratio, water_level=0.0):
    """``U = m g (z - wl) - rho_w g int_sub (z - wl) dA`` per iceberg (docs/model.md)."""
    z = np.asarray(z, dtype=np.float64)
    mass = density_ratio * np.asarray(width) * np.asarray(thickness)
    a, _, sz = submerged_moments(z, theta, 0.5 * np.asarray(width), 0.5 * np.asarray(thickness), water_level)
    return mass * (z - water_level) - (sz + a * (z - water_level))


def below(poly: np.ndarray, level: float) -> np.ndarray:
    """The part of the convex counter-clockwise polygon ``poly`` ((K, 2): x, z) below
    z = ``level`` (Sutherland-Hodgman), independent of the model's edge-by-edge formula."""
    out = []
    n = len(poly)
    for k in range(n):
        p, q = poly[k], poly[(k + 1) % n]
        if p[1] <= level:
            out.append(p)
        if (p[1] < level) != (q[1] < level):
            out.append(p + (level - p[1]) / (q[1] - p[1]) * (q - p))
    return np.array(out)


def area_centroid(poly: np.ndarray) -> tuple[float, float, float]:
    """Area and centroid (x, z) of a counter-clockwise polygon (0 for fewer than 3 corners)."""
    if len(poly) < 3:
        return 0.0, 0.0, 0.0
    x, z = poly[:, 0], poly[:, 1]
    x1, z1 = np.roll(x, -1), np.roll(z, -1)
    cr = x * z1 - x1 * z
    a = cr.sum() / 2
    return float(a), float((cr * (x + x1)).sum() / (6 * a)), float((cr * (z + z1)).sum() / (6 * a))


def clipped_moments(z, theta, w, h, wl=0.0):
    """Area A and first moment Sx = int (x - x_G) dA of a rectangle clipped at z = wl
    (:func:`below`, independent of the model's edge-by-edge formula)."""
    c, s = math.cos(theta), math.sin(theta)
    signs = ((1, -1), (1, 1), (-1, 1), (-1, -1))
    corners = np.array([(su * w / 2 * c - sv * h / 2 * s, z + su * w / 2 * s + sv * h / 2 * c) for su, sv in signs])
    a, xb, _ = area_centroid(below(corners, wl))
    return a, a * xb


# ---------------------------------------------------------------- outlines (any convex polygon)
# An iceberg's outline is a rectangle (``width`` x ``thickness``, the paper's) or a convex
# polygon of 3 to MAX_VERTICES corners, counter-clockwise in the body frame (u, v) about its
# centroid, the centre of mass. Everything the model needs from an outline comes from here
# (host side) and from melange_ti.physics.shape (the kernels).
MAX_VERTICES = 8


def rectangle(width: float, thickness: float) -> np.ndarray:
    """A rectangle's corners about its centre (4, 2), counter-clockwise from the lower right:
    the order the kernels take them in (``physics.shape.hydrostatics.corner``)."""
    w, h = 0.5 * width, 0.5 * thickness
    return np.array([[w, -h], [w, h], [-w, h], [-w, -h]])


def outline_problem(vertices) -> str | None:
    """What keeps ``vertices`` (``[[x, z], ...]``) from being an iceberg's outline, in words
    (what would be accepted), or ``None``: 3 to :data:`MAX_VERTICES` finite corners of a
    convex polygon with an area, listed counter-clockwise, no two equal, no three in a line."""
    try:
        v = np.asarray(vertices, dtype=float)
    except (TypeError, ValueError):
        return "must be a list of [x, z] corners"
    if v.ndim != 2 or v.shape[1] != 2:
        return "must be a list of [x, z] corners"
    k = v.shape[0]
    if not 3 <= k <= MAX_VERTICES:
        return f"has {k} corners; an outline has 3 to {MAX_VERTICES}"
    if not np.all(np.isfinite(v)):
        return "must hold finite numbers"
    scale = float(np.max(np.abs(v - v.mean(axis=0)))) or 1.0
    edge = np.roll(v, -1, axis=0) - v
    if np.any(np.hypot(edge[:, 0], edge[:, 1]) <= 1e-9 * scale):
        return "repeats a corner; list each corner once"
    for p in range(k):  # two edges that are not neighbours may not meet
        for q in range(p + 2, k):
            if p == 0 and q == k - 1:
                continue
            if _segments_meet(v[p], v[(p + 1) % k], v[q], v[(q + 1) % k]):
                return "crosses itself; list the corners in order around the outline, counter-clockwise"
    area = 0.5 * float(np.sum(v[:, 0] * np.roll(v[:, 1], -1) - np.roll(v[:, 0], -1) * v[:, 1]))
    if abs(area) <= 1e-9 * scale * scale:
        return "has no area"
    if area < 0:
        return "is listed clockwise; list the corners counter-clockwise"
    turn = edge[:, 0] * np.roll(edge[:, 1], -1) - edge[:, 1] * np.roll(edge[:, 0], -1)
    lengths = np.hypot(edge[:, 0], edge[:, 1])
    if np.any(turn <= 1e-9 * lengths * np.roll(lengths, -1)):
        return "is not convex (or has three corners in a line); give a convex outline, counter-clockwise"
    return None


def _segments_meet(p1, p2, q1, q2) -> bool:
    def side(a, b, c):
        return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])

    d1, d2 = side(q1, q2, p1), side(q1, q2, p2)
    d3, d4 = side(p1, p2, q1), side(p1, p2, q2)
    return d1 * d2 <= 0 and d3 * d4 <= 0 and not (d1 == d2 == 0)


def polygon_moments(vertices: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """Area, centroid (2,) and the second moments ``(int u^2, int v^2, int u v) dA`` about the
    centroid of a counter-clockwise polygon (K, 2) (Green's theorem, edge by edge)."""
    v = np.asarray(vertices, dtype=float)
    x, z = v[:, 0], v[:, 1]
    x1, z1 = np.roll(x, -1), np.roll(z, -1)
    cr = x * z1 - x1 * z
    area = 0.5 * cr.sum()
    c = np.array([(cr * (x + x1)).sum(), (cr * (z + z1)).sum()]) / (6.0 * area)
    u, w = x - c[0], z - c[1]
    u1, w1 = np.roll(u, -1), np.roll(w, -1)
    cr = u * w1 - u1 * w
    second = np.array(
        [
            (cr * (u * u + u * u1 + u1 * u1)).sum() / 12.0,
            (cr * (w * w + w * w1 + w1 * w1)).sum() / 12.0,
            (cr * (u * w1 + 2 * u * w + 2 * u1 * w1 + u1 * w)).sum() / 24.0,
        ]
    )
    return float(area), c, second


def principal_axis(second: np.ndarray) -> float:
    """The angle ``alpha`` (|alpha| <= pi/4, counter-clockwise) from the body's v axis to the
    principal axis of the area's inertia nearest it: 0 where the inertia has no axes (a
    square, a regular polygon: equal moments, no product) or they are u and v."""
    iuu, ivv, iuv = (float(t) for t in second)
    scale = abs(iuu) + abs(ivv)
    if abs(iuv) <= 1e-12 * scale and abs(iuu - ivv) <= 1e-12 * scale or iuv == 0.0:
        return 0.0
    # the principal directions of the tensor [[iuu, iuv], [iuv, ivv]] (moments int u^2 etc.)
    beta = 0.5 * math.atan2(2.0 * iuv, iuu - ivv)  # the direction of largest int (r . e)^2 from u
    alpha = beta - 0.5 * math.pi  # the same axes, measured from v
    return float((alpha + 0.25 * math.pi) % (0.5 * math.pi) - 0.25 * math.pi)


def outline(vertices, density_ratio: float) -> dict:
    """An outline's constants: corners about the centroid (K, 2), the centroid the corners
    were given about (2,), mass and moment of inertia about the centroid (rho_w = 1), the
    bounding radius, the width and thickness (the extents along u and v), the diameter (the
    longest chord: the longest water line it can float with) and the principal axis
    (:func:`principal_axis`)."""
    v = np.asarray(vertices, dtype=float)
    area, c, second = polygon_moments(v)
    corners = v - c
    radii = np.hypot(corners[:, 0], corners[:, 1])
    d = corners[:, None, :] - corners[None, :, :]
    mass, inertia, bound = density_ratio * area, density_ratio * float(second[0] + second[1]), float(radii.max())
    width, thickness = float(np.ptp(corners[:, 0])), float(np.ptp(corners[:, 1]))
    if len(corners) == 4 and np.array_equal(corners, rectangle(width, thickness)):
        # a rectangle written out (from the lower right): its closed form, the arithmetic of
        # the same rectangle given by width and thickness (Green's sums agree to an ulp)
        m, j = mass_inertia(width, thickness, density_ratio)
        mass, inertia, bound = float(m), float(j), float(0.5 * np.hypot(width, thickness))
    return {
        "corners": corners,
        "centroid": c,
        "mass": mass,
        "inertia": inertia,
        "bound": bound,
        "width": width,
        "thickness": thickness,
        "diameter": float(np.hypot(d[..., 0], d[..., 1]).max()),
        "axis": principal_axis(second),
    }


def body_outlines(icebergs) -> np.ndarray:
    """Every iceberg's corners in its body frame about its centre of mass, (N, K, 2), from a
    run's ``/icebergs`` (a mapping): a polygon's as stored (``corners``, ``corner_u``,
    ``corner_v``), padded by repeating its last corner (a repeated corner draws nothing); a
    rectangle's from ``width`` and ``thickness``."""
    width = np.asarray(icebergs["width"], dtype=float)
    if "corner_u" not in icebergs:
        thickness = np.asarray(icebergs["thickness"], dtype=float)
        return np.stack([rectangle(w, h) for w, h in zip(width, thickness, strict=True)]).reshape(-1, 4, 2)
    out = np.stack([np.asarray(icebergs["corner_u"], dtype=float), np.asarray(icebergs["corner_v"], dtype=float)], -1)
    count = np.asarray(icebergs["corners"], dtype=int)
    for i, k in enumerate(count):
        out[i, k:] = out[i, k - 1]
    return out


def world_outlines(x, z, theta, body: np.ndarray) -> np.ndarray:
    """World corners (N, K, 2) of outlines ``body`` (N, K, 2) at poses ``x, z, theta``."""
    x, z, theta = (np.asarray(a, dtype=float) for a in (x, z, theta))
    c, s = np.cos(theta)[:, None], np.sin(theta)[:, None]
    u, v = body[..., 0], body[..., 1]
    return np.stack([x[:, None] + u * c - v * s, z[:, None] + u * s + v * c], -1)


# ---------------------------------------------------------------- a polygon's collision discs
def inset(corners: np.ndarray, r: float) -> np.ndarray:
    """The outline ``corners`` (K, 2; convex, counter-clockwise) moved inwards by ``r``: each
    corner where the two edges meeting there, each shifted ``r`` along its inward normal,
    cross. A disc of radius ``r`` there touches both edges."""
    p = np.asarray(corners, dtype=float)
    e = np.roll(p, -1, axis=0) - p
    n = np.stack([-e[:, 1], e[:, 0]], -1) / np.hypot(e[:, 0], e[:, 1])[:, None]  # inward (CCW)
    before = np.roll(n, 1, axis=0)  # the edge that ends at corner k
    return p + r * (before + n) / (1.0 + np.sum(before * n, axis=1))[:, None]


def polygon_discs(corners: np.ndarray, discs: int, spacing: float = 2.0) -> tuple[float, np.ndarray, np.ndarray]:
    """:func:`_polygon_discs`, remembered per outline (a shelf repeats few)."""
    p = np.asarray(corners, dtype=float)
    r, q, n = _discs_of(p.tobytes(), len(p), int(discs), float(spacing))
    return r, q.copy(), n.copy()


@functools.lru_cache(maxsize=4096)
def _discs_of(key: bytes, count: int, discs: int, spacing: float):
    return _polygon_discs(np.frombuffer(key, dtype=float).reshape(count, 2), discs, spacing)


def _polygon_discs(corners: np.ndarray, discs: int, spacing: float = 2.0) -> tuple[float, np.ndarray, np.ndarray]:
    """An outline's collision discs, the rectangle's rule for any outline of ``K`` edges:
    ``k = discs // K`` discs on every edge (a rectangle's ``discs / 4`` per face), one radius
    ``r``, their centres on the outline moved inwards by ``r`` (:func:`inset`; so the union
    touches every face and each corner has a disc touching both faces that meet there), each
    edge's from its inset corner in ``k`` equal steps towards the next. The inset edge ``e``
    is ``L_e - r c_e`` long, ``c_e`` the sum of ``cot(angle / 2)`` over its two corners, so its
    discs are ``(L_e - r c_e) / k`` apart; ``r = max_e L_e / (k spacing + c_e)`` is the
    smallest radius that leaves no two neighbours on any edge farther apart than ``spacing r``.
    A rectangle (``c_e = 2``) takes ``r = L / (k spacing + 2)``, :func:`disc_radius`, to the
    bit. Returns ``(r, inset corners (K, 2), n (K,))``; ``r = 0`` when no radius fits: fewer
    discs than edges, or an edge that vanishes inwards (too few ``discs`` for its shape)."""
    p = np.asarray(corners, dtype=float)
    count = len(p)
    k = int(discs) // count
    d = np.roll(p, -1, axis=0) - p
    length = np.hypot(d[:, 0], d[:, 1])
    if k < 1 or np.any(length <= 0):
        return 0.0, p.copy(), np.zeros(count, dtype=np.int64)
    t = d / length[:, None]  # unit directions, edge e from corner e
    before = np.roll(t, 1, axis=0)  # the edge that ends at corner e
    # cot of half the interior angle at corner e: (1 + cos a) / sin a, cos a = -t_in . t_out
    cot = (1.0 - np.sum(before * t, axis=1)) / (before[:, 0] * t[:, 1] - before[:, 1] * t[:, 0])
    c = cot + np.roll(cot, -1)  # at edge e's two corners, e and e + 1
    r = float(np.max(length / (k * spacing + c)))
    q = inset(p, r)
    e = np.roll(q, -1, axis=0) - q
    if np.any(np.sum(e * d, axis=1) < 0):  # an edge turned over: its corners too sharp for k discs
        return 0.0, p.copy(), np.zeros(count, dtype=np.int64)
    return r, q, np.full(count, k, dtype=np.int64)


def polygon_disc_local(corners: np.ndarray, discs: int, spacing: float = 2.0) -> tuple[np.ndarray, float]:
    """Body-frame disc centres (discs, 2) and radius of a polygon (:func:`polygon_discs`):
    edge by edge from each inset corner; past the polygon's own count the last disc repeats
    (the kernels skip those)."""
    r, q, n = polygon_discs(corners, discs, spacing)
    out = []
    for k in range(len(q)):
        a, b = q[k], q[(k + 1) % len(q)]
        out += [a + (j / n[k]) * (b - a) for j in range(n[k])]
    out = np.array(out) if out else np.zeros((1, 2))
    return np.concatenate([out, np.repeat(out[-1:], max(0, discs - len(out)), 0)]), r


def floating_height(corners: np.ndarray, density_ratio: float) -> float:
    """The height of the centroid above the water line at which the outline ``corners``
    (about its centroid, at theta = 0) floats: the submerged share ``density_ratio`` of its
    area (bisection of :func:`below`'s area)."""
    p = np.asarray(corners, dtype=float)
    total = area_centroid(p)[0]
    lo, hi = float(p[:, 1].min()), float(p[:, 1].max())  # the water line relative to the centroid
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if area_centroid(below(p, mid))[0] < density_ratio * total else (lo, mid)
    return -0.5 * (lo + hi)

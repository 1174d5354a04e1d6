"""The initial state: the paper's shelf, a run's snapshot (``[start]``), and the check that
no iceberg overlaps another or the wall at t = 0.

Overlaps are judged with the collision geometry, the discs (not the exact rectangles, whose
corners the discs round off), so any state that the model itself produced is a valid start:
the model's own states keep disc overlaps far below :data:`OVERLAP_TOLERANCE` disc radii.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np

from ..geometry import disc_local, floating_height, outline, polygon_disc_local, rectangle
from ..io.hdf5 import OutputError, SnapshotTimeError, last_snapshot
from .errors import error
from .keys import DT_SAFETY

# the scene (melange_ti.scene.core.Scene) these checks read: not imported, it stands on this module
Scene = Any

# Refuse a start where two icebergs' discs (or a disc and the wall) overlap by more than this
# fraction of the smaller disc radius: deeper, the first correction would throw them apart.
OVERLAP_TOLERANCE = 0.1
_CHUNK = 2048  # pairs whose discs are compared at once


@dataclass(frozen=True)
class Icebergs:
    """Initial state of every iceberg, arrays of shape (N,)."""

    x: np.ndarray
    z: np.ndarray
    theta: np.ndarray
    vx: np.ndarray
    vz: np.ndarray
    omega: np.ndarray
    width: np.ndarray
    thickness: np.ndarray
    # polygons (any [[iceberg]] given by vertices): every outline's corners about its
    # centroid, counter-clockwise (N, V, 2), zero past its count (N,); None: all rectangles
    outline: np.ndarray | None = None
    corners: np.ndarray | None = None
    # cells (an iceberg given with cells = [nx, nz]): each body's iceberg (N,) and its place
    # (ix, iz) in that iceberg's grid (N, 2); None: every body is a whole iceberg
    parent: np.ndarray | None = None
    cell: np.ndarray | None = None

    @property
    def count(self) -> int:
        return int(self.x.shape[0])

    def outlines(self, density_ratio: float) -> list[dict]:
        """Each iceberg's outline constants (:func:`melange_ti.geometry.outline`): its corners,
        a rectangle's from its width and thickness."""
        if self.outline is None:
            return [outline(rectangle(w, h), density_ratio) for w, h in zip(self.width, self.thickness, strict=True)]
        return [outline(self.outline[i, : self.corners[i]], density_ratio) for i in range(self.count)]


def with_outlines(bergs: list[np.ndarray | None], cols: dict) -> Icebergs:
    """Icebergs from the columns ``cols`` and, per iceberg, its outline's corners as given
    (``None``: a rectangle of its width and thickness): each polygon is moved so that its
    centroid, the centre of mass, sits at the iceberg's ``x``, ``z``; its width and thickness
    become its extents along u and v."""
    if all(v is None for v in bergs):
        return Icebergs(**cols)
    n = len(bergs)
    count = max(len(v) if v is not None else 4 for v in bergs)
    shape = np.zeros((n, count, 2))
    corners = np.zeros(n, dtype=np.int64)
    width, thickness = cols["width"].copy(), cols["thickness"].copy()
    for i, v in enumerate(bergs):
        o = outline(rectangle(width[i], thickness[i]) if v is None else v, 1.0)
        k = len(o["corners"])
        shape[i, :k] = o["corners"]
        corners[i] = k
        width[i], thickness[i] = o["width"], o["thickness"]
    return Icebergs(**{**cols, "width": width, "thickness": thickness}, outline=shape, corners=corners)


def _bilinear(bl, br, tr, tl, a: float, b: float) -> np.ndarray:
    """The point at fractions ``a`` along the bottom and top and ``b`` up the sides of the
    quadrilateral of corners ``bl, br, tr, tl``."""
    return (1 - a) * (1 - b) * bl + a * (1 - b) * br + a * b * tr + (1 - a) * b * tl


def partitioned(bergs: Icebergs, cells: list[tuple[int, int]]) -> Icebergs:
    """``bergs`` with iceberg ``i`` cut into ``cells[i] = (nx, nz)`` cells, each a body: nx
    across the width (u), nz through the thickness (v), in the order of the icebergs and,
    within one, column by column from -u, each column from -v. A rectangle's cells are the
    rectangles of its width / nx and thickness / nz; an outline of 4 corners is cut along its
    sides (the bilinear map of its corners, whose lines of constant parameter are straight,
    so neighbouring cells share whole faces): each cell the quadrilateral between them. Every
    cell keeps the iceberg's tilt and moves with it rigidly (``v + omega x r``); the cells tile
    the outline, so their masses, moments about the iceberg's centre and displaced water add
    up to the whole's. ``bergs`` itself if every iceberg is one cell."""
    if all(tuple(c) == (1, 1) for c in cells):
        return bergs
    names = ("x", "z", "theta", "vx", "vz", "omega", "width", "thickness")
    cols: dict[str, list] = {k: [] for k in names}
    shapes: list[np.ndarray | None] = []
    parent, place = [], []
    for i, (nx, nz) in enumerate(cells):
        rect = bergs.outline is None or (bergs.corners[i] == 4 and _is_rectangle(bergs, i))
        w, h = float(bergs.width[i]), float(bergs.thickness[i])
        q = rectangle(w, h) if rect else bergs.outline[i, :4]
        k = int(np.argmax(np.roll(q[:, 1], -1) - q[:, 1]))  # the side that rises: counter-clockwise, the +u one
        br, tr, tl, bl = (q[(k + j) % 4] for j in range(4))
        c, s_ = math.cos(bergs.theta[i]), math.sin(bergs.theta[i])
        for ix in range(nx):
            s0, s1 = ix / nx, (ix + 1) / nx
            for iz in range(nz):
                r0, r1 = iz / nz, (iz + 1) / nz
                quad = np.array([_bilinear(bl, br, tr, tl, a, b) for a, b in ((s1, r0), (s1, r1), (s0, r1), (s0, r0))])
                if rect:
                    centre = np.array([(s0 + s1 - 1.0) * w / 2, (r0 + r1 - 1.0) * h / 2])
                    width, thickness, shape = w / nx, h / nz, None
                else:
                    o = outline(quad, 1.0)
                    centre, shape = np.asarray(o["centroid"], dtype=np.float64), quad - np.asarray(o["centroid"])
                    width, thickness = o["width"], o["thickness"]
                rx, rz = c * centre[0] - s_ * centre[1], s_ * centre[0] + c * centre[1]
                om = float(bergs.omega[i])
                row = (bergs.x[i] + rx, bergs.z[i] + rz, bergs.theta[i], bergs.vx[i] - om * rz, bergs.vz[i] + om * rx, om)
                for key, v in zip(names, (*row, width, thickness), strict=True):
                    cols[key].append(float(v))
                shapes.append(shape)
                parent.append(i)
                place.append((ix, iz))
    arrays = {k: np.array(v) for k, v in cols.items()}
    out = with_outlines(shapes, arrays)
    return Icebergs(
        **{f: getattr(out, f) for f in out.__dataclass_fields__ if f not in ("parent", "cell")},
        parent=np.array(parent, dtype=np.int64),
        cell=np.array(place, dtype=np.int64).reshape(-1, 2),
    )


# what an [[iceberg]] table's z may say instead of a number (or say by leaving z out): the
# height at which its outline floats at its tilt in still water (:func:`floated`)
FLOAT = "float"


def floated(bergs: Icebergs, which: np.ndarray, density_ratio: float, water_level: float) -> Icebergs:
    """``bergs`` with the icebergs ``which`` (a boolean mask) set to float: each centre of mass
    at the height where its outline, tilted by its ``theta``, displaces ``density_ratio`` of
    its area below a still sea at ``water_level`` (its draft in hydrostatic equilibrium; not
    in balance in roll unless the tilt is one). An upright rectangle takes the shelf's exact
    :func:`equilibrium_z`; any other outline the bisection of :func:`geometry.floating_height`
    on its corners turned by ``theta``."""
    z = bergs.z.copy()
    for i in np.flatnonzero(which):
        if bergs.outline is None or (bergs.corners[i] == 4 and _is_rectangle(bergs, i)):
            if bergs.theta[i] == 0.0:
                z[i] = equilibrium_z(bergs.thickness[i], density_ratio, water_level)
                continue
            corners = rectangle(bergs.width[i], bergs.thickness[i])
        else:
            corners = bergs.outline[i, : bergs.corners[i]]
        c, s = math.cos(bergs.theta[i]), math.sin(bergs.theta[i])
        turned = corners @ np.array([[c, s], [-s, c]])  # each corner (u, v) to (u c - v s, u s + v c)
        z[i] = water_level + floating_height(turned, density_ratio)
    return Icebergs(**{**{f: getattr(bergs, f) for f in bergs.__dataclass_fields__}, "z": z})


def _is_rectangle(bergs: Icebergs, i: int) -> bool:
    """Whether iceberg ``i``'s outline is the rectangle of its width and thickness, corner for
    corner (a rectangle given by width and thickness in a scene that also holds polygons)."""
    return bool(np.array_equal(bergs.outline[i, :4], rectangle(bergs.width[i], bergs.thickness[i])))


def equilibrium_z(thickness: np.ndarray | float, density_ratio: float, water_level: float) -> Any:
    """Centre height of an upright iceberg floating in hydrostatic equilibrium (draft r*h)."""
    return water_level - density_ratio * thickness + 0.5 * thickness


def generate_shelf(shelf, physics, seed: int) -> Icebergs:
    """The paper's initial state: a row from the wall, upright, floating, slightly tilted.

    Random numbers are drawn on the host from ``numpy.random.default_rng(seed)``: first the
    tilts, then (only when ``thickness_std > 0``) the thicknesses, then (only when
    ``width_std > 0``) the widths, then (only when ``cut_tilt_std > 0``) the cuts' tilts
    about ``cut_tilt`` (:func:`_cut_shelf`, which also cuts at ``cut_tilt`` alone), so a spread
    never changes what was drawn before it. With spread widths each iceberg keeps ``gap`` to its neighbours (none within an intact
    shelf), as equal ones do.
    """
    rng = np.random.default_rng(seed)
    n = shelf.count
    theta = rng.uniform(-shelf.tilt, shelf.tilt, n) if shelf.tilt > 0 else np.zeros(n)
    thickness = np.full(n, shelf.thickness)
    if shelf.thickness_std > 0:
        thickness = rng.normal(shelf.thickness, shelf.thickness_std, n)
        if np.any(thickness <= 0.05 * shelf.thickness):
            raise error(
                "shelf.thickness_std", shelf.thickness_std, "draws thicknesses <= 5% of shelf.thickness; use a smaller spread"
            )
    width = np.full(n, shelf.width)
    if shelf.width_std > 0:
        width = rng.normal(shelf.width, shelf.width_std, n)
        if np.any(width <= 0.05 * shelf.width):
            raise error("shelf.width_std", shelf.width_std, "draws widths <= 5% of shelf.width; use a smaller spread")
    # the gaps up to each iceberg, from the wall
    start = physics.wall_x + shelf.gap
    gaps = np.arange(n) * shelf.gap
    if shelf.intact:
        # an intact shelf: no gaps (none at the wall either when bonded to it), upright; the
        # seaward ``front`` icebergs free, ``gap`` apart, with their tilts
        last = max(0, n - shelf.front)
        start = physics.wall_x + (0.0 if shelf.bonded_wall else shelf.gap)
        gaps = np.cumsum(np.where(np.arange(n) < last, 0.0, shelf.gap))
        theta = np.where(np.arange(n) < last, 0.0, theta)
    if shelf.width_std > 0:  # each iceberg's left face after the widths before it
        x = start + np.concatenate([[0.0], np.cumsum(width[:-1])]) + gaps + 0.5 * width
    elif shelf.intact:  # equal widths: the formulas the regression hashes were recorded with
        x = start + 0.5 * shelf.width + np.arange(n) * shelf.width + gaps
    else:
        x = start + 0.5 * shelf.width + np.arange(n) * (shelf.width + shelf.gap)
    z = equilibrium_z(thickness, physics.density_ratio, physics.water_level)
    zeros = np.zeros(n)
    cols = dict(x=x, z=z, theta=theta, vx=zeros, vz=zeros.copy(), omega=zeros.copy(), width=width, thickness=thickness)
    if shelf.cut_tilt != 0 or shelf.cut_tilt_std > 0:
        return _cut_shelf(shelf, physics, rng, cols)
    return Icebergs(**cols)


def _cut_shelf(shelf, physics, rng, cols: dict) -> Icebergs:
    """The row with tilted cut faces (``shelf.cut_tilt``, and ``shelf.cut_tilt_std`` drawn after
    everything else): the cut between neighbours k and k + 1 passes through the middle of their
    gap at the water line, tilted by ``alpha_k ~ N(cut_tilt, cut_tilt_std)`` from the vertical
    (positive: its top leans to +x; every ``alpha_k = cut_tilt`` without a spread); each iceberg is the
    quadrilateral between its two cuts (the shelf's ends vertical), each face ``gap / 2`` from
    its cut horizontally, over its own thickness, floated upright at the draft that submerges
    ``density_ratio`` of it. In an intact shelf (``bonded``) no gap is left between bonded
    neighbours and their pieces are not floated one by one: each keeps the height of the
    rectangle it was cut from, so every cut stays closed (the shelf floats as one body; what a
    piece lacks of its own balance the bonds carry)."""
    n = len(cols["x"])
    key = "shelf.cut_tilt_std" if shelf.cut_tilt_std > 0 else "shelf.cut_tilt"
    value = shelf.cut_tilt_std if shelf.cut_tilt_std > 0 else shelf.cut_tilt
    advice = "use a smaller spread" if shelf.cut_tilt_std > 0 else "use a smaller tilt"
    if shelf.cut_tilt_std > 0:
        alpha = rng.normal(shelf.cut_tilt, shelf.cut_tilt_std, max(n - 1, 0))
    else:
        alpha = np.full(max(n - 1, 0), float(shelf.cut_tilt))
    if np.any(np.abs(alpha) >= 0.5 * math.pi):
        raise error(key, value, f"draws cuts tilted 90 degrees or more; {advice}")
    x, z, w, h = cols["x"], cols["z"], cols["width"], cols["thickness"]
    wl = physics.water_level
    # each cut's gap: none between two icebergs of an intact shelf (``bonded``)
    intact = max(0, n - shelf.front) if shelf.intact else 0
    gap = np.full(max(n - 1, 0), float(shelf.gap))
    gap[: max(0, intact - 1)] = 0.0
    mid = x[:-1] + 0.5 * w[:-1] + 0.5 * gap  # each cut's point at the water line
    tan = np.tan(alpha)
    outline_, count = np.zeros((n, 4, 2)), np.full(n, 4, dtype=np.int64)
    xs, zs = np.empty(n), np.empty(n)

    def face(k, level, cut, side):
        """Iceberg k's face on ``cut`` (its right one: side 1) at height ``level``."""
        if cut < 0 or cut >= n - 1:  # the shelf's end: vertical
            return x[k] + side * 0.5 * w[k]
        return mid[cut] + tan[cut] * (level - wl) - side * 0.5 * gap[cut]

    for k in range(n):
        top, bottom = z[k] + 0.5 * h[k], z[k] - 0.5 * h[k]
        quad = np.array(
            [
                [face(k, bottom, k, 1), bottom],
                [face(k, top, k, 1), top],
                [face(k, top, k - 1, -1), top],
                [face(k, bottom, k - 1, -1), bottom],
            ]
        )
        if min(quad[0, 0] - quad[3, 0], quad[1, 0] - quad[2, 0]) <= 0.05 * w[k]:  # nearly a triangle: too sharp a corner
            raise error(
                key,
                value,
                f"draws two cuts that meet within iceberg {k} (its top or bottom narrower than 5% of its width); " + advice,
            )
        o = outline(quad, physics.density_ratio)
        outline_[k] = o["corners"]
        xs[k] = o["centroid"][0]
        if k < intact:  # a piece of the intact shelf: where it was cut
            zs[k] = o["centroid"][1]
        else:
            zs[k] = wl + floating_height(o["corners"], physics.density_ratio)
        w[k], h[k] = o["width"], o["thickness"]
    return Icebergs(**{**cols, "x": xs, "z": zs, "width": w, "thickness": h}, outline=outline_, corners=count)


def from_run(start) -> Icebergs:
    """The state of a run file's last snapshot at or before ``start.time``."""
    path = Path(start.file)
    try:
        stamp = path.stat().st_mtime_ns
    except OSError:
        raise error("start.file", start.file, "not found") from None
    return _snapshot(str(path), float(start.time), stamp)


@lru_cache(maxsize=8)
def _snapshot(path: str, time: float, stamp: int) -> Icebergs:
    try:
        snap = last_snapshot(path, time)
    except SnapshotTimeError as exc:
        raise error("start.time", time, str(exc)) from None
    except OutputError as exc:
        raise error("start.file", path, str(exc).split(": ", 1)[-1]) from None
    return Icebergs(**{k: v for k, v in snap.items() if k != "time"})


def _world_discs(b: Icebergs, idx: np.ndarray, local: np.ndarray) -> np.ndarray:
    c, s = np.cos(b.theta[idx]), np.sin(b.theta[idx])
    u, v = local[idx, :, 0], local[idx, :, 1]
    return np.stack([b.x[idx, None] + u * c[:, None] - v * s[:, None], b.z[idx, None] + u * s[:, None] + v * c[:, None]], -1)


def _extents(width: np.ndarray, thickness: float, radius: float, tilt: float) -> np.ndarray:
    """Largest horizontal half-extent of the disc union of rectangles ``width`` wide tilted
    by up to ``tilt`` (vectorised over the widths, in chunks)."""
    t = np.linspace(0.0, tilt, 1001)
    c, s = np.abs(np.cos(t)), np.abs(np.sin(t))
    iv = 0.5 * thickness - radius
    out = np.empty(width.shape[0])
    for lo in range(0, width.shape[0], 4096):
        iu = 0.5 * width[lo : lo + 4096] - radius
        out[lo : lo + 4096] = np.max(np.abs(iu[:, None]) * c + np.abs(iv) * s, axis=1) + radius
    return out


def _shelf_advice(scene: Scene, b: Icebergs, r: np.ndarray, wall: bool) -> str:
    """What ``shelf.gap`` would leave room for any tilt up to ``shelf.tilt``."""
    sh = scene.shelf
    width, thickness = b.width, b.thickness
    if b.parent is not None:  # cells: a piece tilts as a whole, its cells' discs inside its outline
        pieces = int(b.parent.max()) + 1
        width = np.bincount(b.parent, np.where(b.cell[:, 1] == 0, b.width, 0.0), pieces)
        thickness = np.bincount(b.parent, np.where(b.cell[:, 0] == 0, b.thickness, 0.0), pieces)
    if sh.width_std > 0:  # each iceberg's reach beyond its faces, from its own width: room at the wall and between all
        out = _extents(width, float(thickness.max()), float(r.max()), sh.tilt) - 0.5 * width
        need = float(max(out[0], np.max(out[1:] + out[:-1], initial=0.0)))
    else:
        ext = float(_extents(np.array([sh.width]), float(thickness.max()), float(r.max()), sh.tilt)[0])
        need = ext - 0.5 * sh.width if wall else 2.0 * ext - sh.width
    return f"use shelf.gap >= {math.ceil(need * 1e4) / 1e4:g} (room for any tilt up to shelf.tilt) or a smaller shelf.tilt"


def heave_omega(width: Any, thickness: Any, density_ratio: float) -> Any:
    """Angular frequency of the stiffest hydrostatic oscillation of each iceberg: its heave
    floating flat (the shorter side vertical, draft ``r b``), ``sqrt(g rho_w L / m) =
    sqrt(g / (r b))`` with ``L`` the waterline length and ``m = r w h``. Upright heave is
    slower, and so is roll in either position (docs/model.md, Time stepping)."""
    return np.sqrt(1.0 / (density_ratio * np.minimum(width, thickness)))


def time_step_limit(scene: Scene, icebergs: Icebergs | None = None) -> tuple[float, int] | None:
    """The linear stability limit ``2 / omega`` of the kick-drift step for the scene's stiffest
    iceberg, and which iceberg that is; ``None`` without buoyancy (nothing stiff)."""
    if not scene.effects.buoyancy:
        return None
    b = icebergs if icebergs is not None else scene.icebergs()
    omega = heave_omega(b.width, b.thickness, scene.physics.density_ratio)
    if b.outline is not None:  # a polygon's longest water line is at most its longest chord
        r = scene.physics.density_ratio
        omega = np.array([math.sqrt(o["diameter"] / o["mass"]) for o in b.outlines(r)])
    i = int(np.argmax(omega))
    return 2.0 / float(omega[i]), i


def check_time_step(scene: Scene) -> Icebergs:
    """Refuse a ``time.dt`` above :data:`DT_SAFETY` of the stability limit (unless
    ``time.allow_unstable``); returns the initial state it built."""
    b = scene.icebergs()
    limit = time_step_limit(scene, b)
    dt = scene.time.dt
    if limit is None or scene.time.allow_unstable or dt <= DT_SAFETY * limit[0]:
        return b
    ok = DT_SAFETY * limit[0]
    shown = math.floor(ok / 10 ** math.floor(math.log10(ok) - 2)) * 10 ** math.floor(math.log10(ok) - 2)
    raise error(
        "time.dt",
        dt,
        f"above the stability limit 2/omega = {limit[0]:.3g} of iceberg {limit[1]}'s heave (omega = "
        f"{2.0 / limit[0]:.3g}); use at most {shown:.3g} ({DT_SAFETY:g} of the limit: docs/model.md, Time stepping), "
        "or time.allow_unstable = true to run it anyway",
    )


def check_geometry(scene: Scene, icebergs: Icebergs | None = None) -> None:
    """Refuse a start with a non-finite pose or overlapping icebergs (``icebergs``: the
    initial state if already built)."""
    b = icebergs if icebergs is not None else scene.icebergs()
    for name in ("x", "z", "theta"):
        arr = getattr(b, name)
        if not np.all(np.isfinite(arr)):
            raise error(f"iceberg.{name}", arr[~np.isfinite(arr)][0], "must be finite")
    if not scene.effects.contacts:
        return
    spacing = scene.contacts.disc_spacing
    if b.outline is not None:  # polygons: each one's own discs (geometry.polygon_discs)
        layouts = [polygon_disc_local(b.outline[i, : b.corners[i]], scene.contacts.discs, spacing) for i in range(b.count)]
        worst = next((i for i, (_, r) in enumerate(layouts) if r <= 0), None)
        if worst is not None:
            raise error(
                "contacts.discs",
                scene.contacts.discs,
                f"too few for iceberg {worst}'s outline: no disc radius leaves its discs no farther apart than "
                f"{spacing:g} radii without an edge vanishing; use more",
            )
        local, r = np.stack([q for q, _ in layouts]), np.array([r for _, r in layouts])
    else:
        local, r = _rectangle_discs(scene, b)
    if scene.effects.wall:
        _check_wall(scene, b, local, r)
    if scene.effects.collisions and b.count > 1:
        _check_pairs(scene, b, local, r)


def _rectangle_discs(scene: Scene, b: Icebergs) -> tuple[np.ndarray, np.ndarray]:
    """The rectangles' discs (:func:`..geometry.disc_local`), refusing too few for an aspect ratio."""
    # The radius may not exceed half the shortest face: L / (k s + 2) <= l / 2.
    spacing = scene.contacts.disc_spacing
    aspect = np.maximum(b.width, b.thickness) / np.minimum(b.width, b.thickness)
    k = scene.contacts.discs // 4
    worst = int(np.argmax(aspect))
    if 2.0 * aspect[worst] > k * spacing + 2.0 + 1e-12:
        need = 4 * max(2, math.ceil((2.0 * aspect[worst] - 2.0) / spacing - 1e-12))
        raise error(
            "contacts.discs",
            scene.contacts.discs,
            f"too few for iceberg {worst} of aspect ratio {aspect[worst]:.3g}: disc spacing on its long face "
            f"would exceed 2*radius (holes); use at least {need}",
        )
    return disc_local(b.width, b.thickness, scene.contacts.discs, spacing)


def _where(scene: Scene, i: int) -> tuple[str, Any]:
    """The key the user wrote for iceberg i's position."""
    if scene.shelf is not None:
        return "shelf.gap", scene.shelf.gap
    if scene.start is not None:
        return "start.time", scene.start.time
    return f"iceberg[{i}].x", float(scene.iceberg_table[i].get("x", 0.0))


def _check_wall(scene: Scene, b: Icebergs, local: np.ndarray, r: np.ndarray) -> None:
    wall_x = scene.physics.wall_x
    for lo in range(0, b.count, _CHUNK):
        idx = np.arange(lo, min(lo + _CHUNK, b.count))
        p = _world_discs(b, idx, local)
        depth = (wall_x - (p[:, :, 0] - r[idx, None])).max(axis=1) / r[idx]
        bad = np.flatnonzero(depth > OVERLAP_TOLERANCE)
        if bad.size:
            i = int(idx[bad[0]])
            key, value = _where(scene, i)
            what = f"iceberg {i} overlaps the wall at x = {wall_x:g} at t = 0 by {depth[bad[0]]:.3g} disc radii"
            if scene.shelf is not None:
                what = f"with shelf.tilt = {scene.shelf.tilt:g}, {what}; {_shelf_advice(scene, b, r, True)}"
            raise error(key, value, what)


def _check_pairs(scene: Scene, b: Icebergs, local: np.ndarray, r: np.ndarray) -> None:
    bound = 0.5 * np.hypot(b.width, b.thickness)
    if b.outline is not None:  # polygons: the farthest corner (zeros past a count are nearer)
        bound = np.hypot(b.outline[..., 0], b.outline[..., 1]).max(axis=1)
    order = np.argsort(b.x, kind="stable")
    xs = b.x[order]
    reach = 2.0 * bound.max()
    pairs = []
    for d in range(1, b.count):  # neighbours d apart in x order, while any is within reach
        near = np.flatnonzero(xs[d:] - xs[:-d] < reach)
        if near.size == 0:
            break
        i, j = order[near], order[near + d]
        close = np.hypot(b.x[i] - b.x[j], b.z[i] - b.z[j]) < bound[i] + bound[j]
        pairs.append(np.stack([np.minimum(i, j)[close], np.maximum(i, j)[close]], 1))
    if not pairs:
        return
    pairs = np.concatenate(pairs)
    pairs = pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))]
    for lo in range(0, len(pairs), _CHUNK):
        i, j = pairs[lo : lo + _CHUNK, 0], pairs[lo : lo + _CHUNK, 1]
        pi, pj = _world_discs(b, i, local), _world_discs(b, j, local)
        dist = np.linalg.norm(pi[:, :, None, :] - pj[:, None, :, :], axis=-1)
        depth = ((r[i] + r[j])[:, None, None] - dist).max(axis=(1, 2)) / np.minimum(r[i], r[j])
        bad = np.flatnonzero(depth > OVERLAP_TOLERANCE)
        if bad.size:
            a, c = int(i[bad[0]]), int(j[bad[0]])
            key, value = _where(scene, c)
            what = f"iceberg {c} overlaps iceberg {a} at t = 0 (their discs by {depth[bad[0]]:.3g} disc radii)"
            if scene.shelf is not None:
                what = f"with shelf.tilt = {scene.shelf.tilt:g}, {what}; {_shelf_advice(scene, b, r, False)}"
            raise error(key, value, what)

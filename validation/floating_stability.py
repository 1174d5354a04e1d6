"""Floating stability against theory: the orientation and draft a lone iceberg settles to
(with drag) against the global minimum of its potential energy, and its small roll period
against the metacentric height, for a square and the paper's 1 x 1.4 block at density ratios
0.1-0.9, and for four polygons (issue 33) at 0.2-0.9.

    python validation/floating_stability.py --out validation/results
    python validation/floating_stability.py --polygons-only --out validation/results  # ~7 min

**Theory, computed independently in numpy.** At an angle ``theta`` the block floats at the
water line that leaves ``r A`` of it submerged (bisection of the clipped area); its potential
energy is then ``U(theta) = -rho g r A z_B`` with ``z_B`` the submerged part's centroid above
the block's centre of mass (``m g z_G - rho g int_sub z dA`` at that draft). The clipping is
Sutherland-Hodgman on the block's corners (:func:`melange_ti.geometry.below`, not the
model's edge-by-edge formula; :func:`melange_ti.testing.floating`, shared with the tests).
``U`` is swept over every orientation on a fine grid and its global minimum refined by
golden section. A square floats flat (a face up) only
for ``r < (3 - sqrt 3) / 6 = 0.2113`` or ``r > 0.7887``, where its metacentric height
``GM = 1 / (12 r) + r / 2 - 1/2`` is positive; in between it floats tilted, corner-up in the
middle. Flat and stable, a block of width ``w`` (the water line's length) and thickness ``h``
at draft ``r h`` rolls with ``I omega^2 = m g GM``, ``GM = w^2 / (12 r h) - h (1 - r) / 2``,
``I = m (w^2 + h^2) / 12``.

**The model.** One block per density ratio (``gravity``, ``buoyancy``, ``drag`` with
``drag = angular_drag = 0.5``, dt = 0.01), started upright-flat with a tilt of 0.05 rad, run
to t = 3000; its settled angle (folded by the block's symmetry) and centre height are compared
with the minimum: within 0.5 degrees and 1e-6 (issue 33's bounds). Its roll period, without
drag, from a tilt of 1e-3 rad off a stable flat position (upright, or else on its side),
against ``2 pi / omega`` within 1%.
Writes ``floating_stability.csv`` and ``floating_stability.png`` and prints the table.

**Polygons.** Corners as a scene gives them (:data:`SHAPES`: body frame at theta = 0,
counter-clockwise, not about their centroid, which the model puts at the iceberg's x, z):
an equilateral triangle of side 1, vertex up at theta = 0 (symmetry 2 pi / 3); a right
triangle with legs 1 (along x) and 0.6; an isosceles trapezoid 1 wide at its base, 0.6 at its
top, 0.5 high; an irregular pentagon (0, 0), (0.9, 0.1), (1.05, 0.55), (0.45, 0.85),
(-0.1, 0.45); each at r = 0.2, 0.35, 0.5, 0.65, 0.8, 0.9, and the equilateral triangle also
at 0.45 and 0.55: it floats vertex up below r = 7/16 (where its GM turns negative), vertex
down above 9/16 and tilted, asymmetric, between. The same numpy minimum, over the
shape's symmetry period (720 angles). All but the equilateral triangle have two local
minima over a turn (an orientation and, roughly, its upside-down one; ``local_minima`` in
the CSV). ``U_r(theta + pi) = U_(1-r)(theta) + const`` (turning a polygon over swaps its
submerged and emerged parts), so at r = 1/2 both are global minima, of equal energy and
opposite centre heights, and the equilateral triangle's potential has period pi/3 there.
The model is not asked to find the global minimum: it starts 0.1 rad off it (turned
counter-clockwise), at rest at its floating draft, inside its basin, which the script
checks (``start_energy_share`` < 1: the start's energy below the lower of the neighbouring
maxima; the energy never rises with drag, and ``U(z, theta)`` is at least its value at the
floating draft, so the angle cannot leave the basin). Drag 0.5 damps every mode here (all
underdamped) as ``exp(-t/4)``: every case is inside the bounds by t = 40 (``settle_time``);
run to t = 200. The angle is compared modulo the shape's symmetry.

**Small roll of a polygon.** About a floating position, in ``q = (z, theta)`` (``x`` drops
out: the hydrostatic force is vertical, and the mass matrix about the centre of mass is
diagonal), ``M q'' + K q = 0`` with ``M = diag(m, I)`` and, ``rho g = 1``::

    K_zz = L,   K_ztheta = L d,   K_thetatheta = V GM + L d^2,   GM = L^3 / (12 V) - BG

``L``: the water line's length; ``d``: its midpoint's (the centre of flotation's) offset in
x from the centre of mass, theta counter-clockwise; ``V = r A`` the submerged area;
``BG = z_G - z_B``. Why: ``dU/dz = m - V`` and raising the body by dz lifts ``L dz`` out of
the water, so ``K_zz = L``; turning it by dtheta lifts the water line's point at offset s by
``s dtheta``, so ``dV/dtheta = -L d`` and ``K_ztheta = L d``; the buoyancy's torque about G
is ``V x_B``, and (Reynolds' transport over the submerged part, whose points the turn moves
by ``(-(z - z_G), x - x_G) dtheta`` while the water line stays) ``d(V x_B)/dtheta =
-V (z_B - z_G) - int s^2 ds = V BG - L^3 / 12 - L d^2``, so ``K_thetatheta = V GM + L d^2``.
This holds at any orientation's floating draft; the CSV's ``hessian_error`` is its
difference from a central-difference Hessian of the numpy potential (the tests check a few
orientations), and eliminating the heave leaves ``V GM``, the curvature of U at the floating
draft (stable for GM > 0, whatever d). With ``d = 0`` (the symmetric positions) the roll
decouples, ``I omega^2 = m g GM``; otherwise ``det(K - omega^2 M) = 0``, the roll being the
mode whose mass-weighted shape is more rotation than heave. ``I = r int (x^2 + z^2) dA``
from the corners (:func:`polar_moment`). The model starts in that mode (tilt 1e-3 rad, the
mode's heave with it, no drag) and its period is read from zero crossings of the tilt over
about eight periods, against ``2 pi / omega`` within 1%. The equilateral triangle at
r = 1/2 floats with a corner on the water line, where U's third derivative jumps: its
period's error grows linearly with the tilt (1.2% at 1e-2, 0.12% at 1e-3, 1.2e-4 at 1e-4).
Writes ``floating_stability_polygons.csv`` and ``floating_stability_polygons.png``.
"""

from __future__ import annotations

import argparse
import csv
import math
from pathlib import Path

import numpy as np

RATIOS = tuple(float(v) for v in np.round(np.arange(0.1, 0.91, 0.05), 2))
# the square's tilted equilibria lie between the flat and the corner-up ranges
SQUARE_EXTRA = (0.21, 0.22, 0.23, 0.24, 0.76, 0.77, 0.78, 0.79)
BLOCKS = {"square": (1.0, 1.0), "paper block": (1.0, 1.4)}
DRAG = 0.5
TILT0 = 0.05
SETTLE = 3000.0  # next to the square's bifurcations (r = 0.21, 0.79) the roll is slow and overdamped
DT = 0.01


# ---------------------------------------------------------------- theory (numpy)
def minimum(w: float, h: float, r: float) -> tuple[float, float]:
    """The global minimum of the floating potential over every orientation (numpy,
    :func:`melange_ti.testing.floating_minimum`): (folded angle, centre height)."""
    from melange_ti.testing import floating_minimum, rectangle

    square = w == h
    theta, z = floating_minimum(rectangle(w, h), r, math.pi / 2 if square else math.pi, 720)
    return fold(theta, square), z


def fold(theta: float, square: bool) -> float:
    """The angle from the nearest flat position (a face up), by the block's symmetry."""
    period = math.pi / 2 if square else math.pi
    return abs((theta + period / 2) % period - period / 2)


def roll_omega(w: float, h: float, r: float) -> float | None:
    """Small-roll angular frequency about the flat position with thickness h vertical, or
    None where that position is unstable (GM <= 0)."""
    gm = w**2 / (12 * r * h) - h * (1 - r) / 2
    return math.sqrt(12 * gm / (w**2 + h**2)) if gm > 0 else None


# ---------------------------------------------------------------- the model
def settle(w: float, h: float, r: float, drag: float, theta0: float, duration: float, every: int = 0):
    """A lone block from the flat position tilted by theta0: its final (theta, z), and with
    ``every`` its tilt every so many steps."""
    from melange_ti.model import Model
    from melange_ti.scene.initial import equilibrium_z
    from melange_ti.testing import make_scene

    bergs = [{"x": 0.0, "z": equilibrium_z(h, r, 0.0), "theta": theta0, "width": w, "thickness": h}]
    physics = {"density_ratio": r, "drag": drag, "angular_drag": drag, "wall_x": -50.0}
    m = Model(make_scene(["gravity", "buoyancy", "drag"], bergs, physics, dt=DT))
    steps = int(round(duration / DT))
    if not every:
        m.advance(steps)
        s = m.state()
        return float(s["theta"][0]), float(s["z"][0]), None
    tilts = []
    for _ in range(steps // every):
        m.advance(every)
        tilts.append(float(m.state()["theta"][0]))
    s = m.state()
    return float(s["theta"][0]), float(s["z"][0]), np.array(tilts)


def roll_period(w: float, h: float, r: float) -> float:
    """The roll's period from zero crossings over about eight periods of the theory's."""
    from melange_ti.testing import zero_crossing_period

    every = 5
    _, _, tilts = settle(w, h, r, 0.0, 1e-3, 8 * 2 * math.pi / roll_omega(w, h, r) + 10.0, every)
    t = every * DT * np.arange(1, len(tilts) + 1)
    return zero_crossing_period(t, tilts, least=5)


# ---------------------------------------------------------------- polygons: theory (numpy)
# body-frame corners at theta = 0, counter-clockwise, as a scene gives them (not about their
# centroid: the model puts the centroid at the iceberg's x, z), the rotational symmetry, and
# whether the shape is its own mirror image about the vertical at theta = 0 (the figure folds
# its angles by it)
SHAPES = {
    "equilateral triangle": (((0.0, 0.0), (1.0, 0.0), (0.5, math.sqrt(3) / 2)), 3, True),
    "right triangle": (((0.0, 0.0), (1.0, 0.0), (0.0, 0.6)), 1, False),
    "trapezoid": (((-0.5, 0.0), (0.5, 0.0), (0.3, 0.5), (-0.3, 0.5)), 1, True),
    "pentagon": (((0.0, 0.0), (0.9, 0.1), (1.05, 0.55), (0.45, 0.85), (-0.1, 0.45)), 1, False),
}
POLY_RATIOS = (0.2, 0.35, 0.5, 0.65, 0.8, 0.9)
# the equilateral triangle floats vertex up below r = 7/16, vertex down above 9/16, tilted between
POLY_EXTRA = {"equilateral triangle": (0.45, 0.55)}
OFFSET = 0.1  # the start, off the minimum (rad), inside its basin (checked: below_barrier)
POLY_SETTLE = 200.0  # every case is inside the bounds by t = 60 (settle_time in the CSV)
ROLL_TILT = 1e-3


def outline(name: str) -> tuple[np.ndarray, float]:
    """The shape's corners about its centroid (the centre of mass) and its symmetry period."""
    from melange_ti.geometry import area_centroid

    corners, order, _ = SHAPES[name]
    p = np.array(corners, dtype=float)
    _, cx, cz = area_centroid(p)
    return p - [cx, cz], 2 * math.pi / order


def wrap(angle: float, period: float) -> float:
    """``angle`` folded into [-period/2, period/2)."""
    return (angle + period / 2) % period - period / 2


def shown(theta: float, period: float) -> float:
    """``theta`` in [0, period), a hair below ``period`` (a minimum at -1e-12) taken as 0."""
    a = theta % period
    return a if period - a > 1e-6 else 0.0


def polar_moment(p: np.ndarray) -> float:
    """``int (x^2 + z^2) dA`` of the polygon ``p`` about the origin (its centroid)."""
    x, z = p[:, 0], p[:, 1]
    x1, z1 = np.roll(x, -1), np.roll(z, -1)
    cr = x * z1 - x1 * z
    return float((cr * (x * x + x * x1 + x1 * x1 + z * z + z * z1 + z1 * z1)).sum() / 12)


def potential(p: np.ndarray, r: float, z: float, theta: float) -> float:
    """``U / (rho g)`` of the polygon ``p`` (about its centroid) of density ratio ``r`` with its
    centre of mass at height ``z`` (the water line at 0), turned by ``theta``; x is free."""
    from melange_ti.geometry import area_centroid, below
    from melange_ti.testing import rotated

    a_sub, _, z_sub = area_centroid(below(rotated(p, theta) + [0.0, z], 0.0))
    return r * area_centroid(p)[0] * z - a_sub * z_sub


def potential_at_draft(p: np.ndarray, r: float, theta: float) -> float:
    from melange_ti.testing import floating

    return floating(p, r, theta)[0]


def hydrostatics(p: np.ndarray, r: float, theta: float) -> dict:
    """At the draft that floats ``p`` turned by ``theta``: the water line's length ``L`` and
    its midpoint's offset ``d`` from the centre of mass (x, world frame), the submerged area
    ``V``, ``BG = z_G - z_B``, ``GM = L^3 / (12 V) - BG``, ``z`` (of the centre), and the
    stiffness ``K`` (the potential's Hessian in (z, theta))."""
    from melange_ti.geometry import area_centroid, below
    from melange_ti.testing import floating, rotated

    z = floating(p, r, theta)[1]
    q = rotated(p, theta) + [0.0, z]
    cuts = [
        a[0] - a[1] * (b[0] - a[0]) / (b[1] - a[1])
        for a, b in zip(q, np.roll(q, -1, axis=0), strict=True)
        if (a[1] < 0.0) != (b[1] < 0.0)
    ]
    length, d = max(cuts) - min(cuts), 0.5 * (max(cuts) + min(cuts))
    v, _, zb = area_centroid(below(q, 0.0))
    bg = z - zb
    gm = length**3 / (12 * v) - bg
    k = np.array([[length, length * d], [length * d, v * gm + length * d * d]])
    return {"L": length, "d": d, "V": v, "BG": bg, "GM": gm, "z": z, "K": k}


def fd_hessian(p: np.ndarray, r: float, z: float, theta: float, h: float = 1e-4) -> np.ndarray:
    """The Hessian of :func:`potential` in (z, theta) by central differences."""

    def u(a, b):
        return potential(p, r, z + a, theta + b)

    hz = (u(h, 0) - 2 * u(0, 0) + u(-h, 0)) / h**2
    ht = (u(0, h) - 2 * u(0, 0) + u(0, -h)) / h**2
    hzt = (u(h, h) - u(h, -h) - u(-h, h) + u(-h, -h)) / (4 * h * h)
    return np.array([[hz, hzt], [hzt, ht]])


def roll_mode(p: np.ndarray, r: float, theta: float) -> dict:
    """The small oscillations about the floating position ``theta``: ``M q'' + K q = 0`` in
    ``q = (z, theta)``, ``M = diag(m, I)``. The roll is the mode whose mass-weighted shape is
    more rotation than heave; ``dz``: its heave per radian of roll. Also the decoupled roll's
    ``I omega^2 = m g GM`` (exact when ``d = 0``)."""
    from melange_ti.geometry import area_centroid

    h = hydrostatics(p, r, theta)
    mass, inertia = r * area_centroid(p)[0], r * polar_moment(p)
    s = np.array([math.sqrt(mass), math.sqrt(inertia)])
    w2, vec = np.linalg.eigh(h["K"] / np.outer(s, s))  # symmetric: M^-1/2 K M^-1/2
    k = int(np.argmax(np.abs(vec[1])))
    shape = vec[:, k] / s
    return {
        **h,
        "omega": math.sqrt(w2[k]),
        "omega_heave": math.sqrt(w2[1 - k]),
        "dz": float(shape[0] / shape[1]),
        "omega_decoupled": math.sqrt(mass * h["GM"] / inertia) if h["GM"] > 0 else float("nan"),
    }


def local_minima(p: np.ndarray, r: float, period: float, grid: int = 360) -> list[float]:
    """The angles of the floating potential's local minima on a sweep over one period."""
    angles = np.linspace(0.0, period, grid, endpoint=False)
    u = np.array([potential_at_draft(p, r, t) for t in angles])
    return [float(angles[k]) for k in range(grid) if u[k] < u[k - 1] and u[k] <= u[(k + 1) % grid]]


def below_barrier(p: np.ndarray, r: float, theta: float, theta0: float, step: float = 0.01) -> float:
    """``(U(theta0) - U(theta)) / (barrier - U(theta))``: below 1, a start at rest from
    ``theta0`` (at its floating draft) stays in the minimum ``theta``'s basin, whatever the
    drag, since its energy never exceeds ``U(theta0)`` and ``U(z, theta) >= U(theta)`` at the
    floating draft. The barrier is the lower of the neighbouring maxima, walked to from
    ``theta`` on a grid of ``step``; NaN if ``theta0`` lies beyond one."""
    u0, umin = potential_at_draft(p, r, theta0), potential_at_draft(p, r, theta)
    barrier, reach = [], []
    for sign in (-1, 1):
        k, prev = 1, umin
        while (u := potential_at_draft(p, r, theta + sign * k * step)) > prev:
            k, prev = k + 1, u
        barrier.append(prev)
        reach.append((k - 1) * step)
    side = 0 if theta0 < theta else 1
    if abs(theta0 - theta) >= reach[side]:
        return float("nan")
    return (u0 - umin) / (min(barrier) - umin)


# ---------------------------------------------------------------- polygons: the model
def polygon_model(name: str, r: float, drag: float, theta: float, z: float):
    """A lone polygon (``gravity``, ``buoyancy``, ``drag``) at rest at (0, z) turned by theta,
    its corners as :data:`SHAPES` gives them."""
    from melange_ti.model import Model
    from melange_ti.testing import make_scene

    bergs = [{"x": 0.0, "z": z, "theta": theta, "vertices": [list(v) for v in SHAPES[name][0]]}]
    physics = {"density_ratio": r, "drag": drag, "angular_drag": drag, "wall_x": -50.0}
    return Model(make_scene(["gravity", "buoyancy", "drag"], bergs, physics, dt=DT))


def settle_polygon(name: str, r: float, theta0: float, theta: float, z: float, duration: float):
    """From rest at ``theta0`` (at its floating draft), with drag: the final (theta, z) and the
    time from which the angle stays within 0.5 degrees of ``theta`` and the centre within
    1e-6 of ``z`` (sampled every time unit)."""
    from melange_ti.testing import floating

    p, period = outline(name)
    m = polygon_model(name, r, DRAG, theta0, floating(p, r, theta0)[1])
    every = int(round(1.0 / DT))
    inside_since = None
    for k in range(int(round(duration / DT)) // every):
        m.advance(every)
        s = m.state()
        ok = math.degrees(abs(wrap(float(s["theta"][0]) - theta, period))) < 0.5 and abs(float(s["z"][0]) - z) < 1e-6
        inside_since = (inside_since if inside_since is not None else (k + 1) * every * DT) if ok else None
    s = m.state()
    return float(s["theta"][0]), float(s["z"][0]), inside_since if inside_since is not None else float("nan")


def polygon_roll_period(name: str, r: float, theta: float, mode: dict) -> float:
    """The model's roll period, without drag, started in the roll mode (tilt ROLL_TILT, heave
    ``dz`` times it) off the floating position ``theta``: zero crossings of the tilt over about
    eight of the theory's periods."""
    from melange_ti.testing import zero_crossing_period

    every = 5
    m = polygon_model(name, r, 0.0, theta + ROLL_TILT, mode["z"] + ROLL_TILT * mode["dz"])
    tilts = []
    for _ in range(int(round((8 * 2 * math.pi / mode["omega"] + 10.0) / DT)) // every):
        m.advance(every)
        tilts.append(float(m.state()["theta"][0]) - theta)
    t = every * DT * np.arange(1, len(tilts) + 1)
    return zero_crossing_period(t, np.array(tilts), least=5)


def polygon_case(name: str, r: float) -> dict:
    """One shape at one density ratio: theory, the settled model, the roll."""
    from melange_ti.testing import floating_minimum

    p, period = outline(name)
    theta, z = floating_minimum(p, r, period, 720)
    mode = roll_mode(p, r, theta)
    k_fd = fd_hessian(p, r, z, theta)
    theta0 = theta + OFFSET
    share = below_barrier(p, r, theta, theta0)
    if not share < 1:
        raise SystemExit(f"{name} at r = {r}: the start {theta0:.4f} is not inside the minimum's basin")
    theta_m, z_m, t_in = settle_polygon(name, r, theta0, theta, z, POLY_SETTLE)
    return {
        "shape": name,
        "density_ratio": r,
        "local_minima": len(local_minima(p, r, period)),
        "start_energy_share": share,
        "theory_deg": math.degrees(shown(theta, period)),
        "model_deg": math.degrees(shown(theta, period) + wrap(theta_m - theta, period)),
        "angle_error_deg": math.degrees(abs(wrap(theta_m - theta, period))),
        "theory_z": z,
        "model_z": z_m,
        "z_error": abs(z_m - z),
        "settle_time": t_in,
        "waterline_L": mode["L"],
        "offset_d": mode["d"],
        "GM": mode["GM"],
        "hessian_error": float(np.abs(mode["K"] - k_fd).max() / np.abs(mode["K"]).max()),
        "roll_period_decoupled": 2 * math.pi / mode["omega_decoupled"],
        "roll_period_theory": 2 * math.pi / mode["omega"],
        "roll_period_model": polygon_roll_period(name, r, theta, mode),
    }


def polygons(out: Path) -> None:
    rows = []
    for name in SHAPES:
        for r in sorted(POLY_RATIOS + POLY_EXTRA.get(name, ())):
            rows.append(q := polygon_case(name, r))
            print(
                f"{name:20s} r = {r:.2f}: {q['model_deg']:9.4f} deg (theory {q['theory_deg']:9.4f}, "
                f"{q['local_minima']} minima), z {q['model_z']:+.8f} ({q['theory_z']:+.8f}) by t = {q['settle_time']:.0f}, "
                f"d {q['offset_d']:+.4f}, roll period {q['roll_period_model']:.5f} ({q['roll_period_theory']:.5f}; "
                f"decoupled {q['roll_period_decoupled']:.5f}), Hessian {q['hessian_error']:.1e}",
                flush=True,
            )
    write_rows(out / "floating_stability_polygons.csv", rows)
    plot_polygons(rows, out / "floating_stability_polygons.png")
    rel = [abs(q["roll_period_model"] / q["roll_period_theory"] - 1) for q in rows]
    print(
        f"largest angle error {max(q['angle_error_deg'] for q in rows):.2e} deg, centre height "
        f"{max(q['z_error'] for q in rows):.2e}, roll period {max(rel):.2e} relative, settled by t = "
        f"{max(q['settle_time'] for q in rows):.0f}, Hessian {max(q['hessian_error'] for q in rows):.1e}"
    )


def folded(name: str, deg: float) -> float:
    """A mirror-symmetric shape's angle (degrees, in [0, period)) from theta = 0, either way."""
    return min(deg, 360 / SHAPES[name][1] - deg) if SHAPES[name][2] else deg


def plot_polygons(rows: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from melange_ti.testing import floating_minimum

    fig, ax = plt.subplots(2, len(SHAPES), figsize=(14, 6.5), constrained_layout=True)
    fine = np.round(np.arange(0.1, 0.901, 0.025), 3)
    for k, name in enumerate(SHAPES):
        p, period = outline(name)
        q = [row for row in rows if row["shape"] == name]
        r = [row["density_ratio"] for row in q]
        top = math.degrees(period) / (2 if SHAPES[name][2] else 1)

        # the theory's curves between the cases (a coarser sweep: where two minima are almost
        # equal, next to r = 1/2, it may take the other one a little early)
        ang, per, dec = [], [], []
        for v in fine:
            theta = floating_minimum(p, float(v), period, 180)[0]
            mode = roll_mode(p, float(v), theta)
            ang.append(folded(name, math.degrees(shown(theta, period))))
            per.append(2 * math.pi / mode["omega"])
            dec.append(2 * math.pi / mode["omega_decoupled"])
        ang = np.array(ang)
        ang[1:][np.abs(np.diff(ang)) > 45] = np.nan  # a jump between minima: no line across it
        ax[0, k].plot(fine, ang, "-", color="0.5", label="minimum of U (numpy)")
        ax[0, k].plot(
            r, [folded(name, row["model_deg"]) for row in q], "o", mfc="none", color="C0", label="model, settled with drag"
        )
        ax[0, k].set_ylim(-0.03 * top, 1.03 * top)
        poly = np.vstack([p, p[:1]])
        inset = ax[0, k].inset_axes([0.72, 0.3 if k == 0 else 0.72, 0.26, 0.26])
        inset.fill(poly[:, 0], poly[:, 1], color="C0", alpha=0.3)
        inset.set_aspect("equal")
        inset.axis("off")
        ax[0, k].set_title(name)
        ax[0, k].set_ylabel(f"angle from theta = 0{', either way' if SHAPES[name][2] else ''} (degrees)")
        ax[1, k].plot(fine, per, "-", color="0.5", label="theory, (heave, roll) coupled")
        ax[1, k].plot(fine, dec, ":", color="0.5", label="I omega^2 = m g GM")
        ax[1, k].plot(r, [row["roll_period_model"] for row in q], "o", mfc="none", color="C1", label="model, no drag")
        ax[1, k].set_xlabel("density ratio r")
        ax[1, k].set_ylabel("small roll period")
    ax[0, 0].legend(loc="lower left", fontsize=8)
    ax[1, 0].legend(loc="upper left", fontsize=8)
    fig.savefig(path, dpi=120)


def write_rows(path: Path, rows: list[dict]) -> None:
    with open(path, "w", newline="") as f:
        wr = csv.DictWriter(f, fieldnames=list(rows[0]))
        wr.writeheader()
        wr.writerows(rows)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", default="validation/results")
    p.add_argument("--plot-only", action="store_true", help="redraw the figures from the CSVs in --out")
    p.add_argument("--polygons-only", action="store_true", help="the polygons alone (not the square and the paper block)")
    a = p.parse_args()
    out = Path(a.out)
    if a.plot_only:
        if not a.polygons_only:
            with open(out / "floating_stability.csv") as f:
                rows = [{k: (v if k == "block" else float(v)) for k, v in row.items()} for row in csv.DictReader(f)]
            plot(rows, out / "floating_stability.png")
        with open(out / "floating_stability_polygons.csv") as f:
            rows = [{k: (v if k == "shape" else float(v)) for k, v in row.items()} for row in csv.DictReader(f)]
        plot_polygons(rows, out / "floating_stability_polygons.png")
        return
    from melange_ti import runtime

    runtime.init("cpu", precision="f64")
    out.mkdir(parents=True, exist_ok=True)
    if not a.polygons_only:
        blocks(out)
    polygons(out)


def blocks(out: Path) -> None:
    rows = []
    for name, (w, h) in BLOCKS.items():
        for r in sorted(RATIOS + (SQUARE_EXTRA if w == h else ())):
            angle, z = minimum(w, h, r)
            theta, zm, _ = settle(w, h, r, DRAG, TILT0, SETTLE)
            # the roll about a stable flat position: thickness h vertical, or else on its side
            # (the same block as a rectangle h wide and w thick)
            rw, rh = (w, h) if roll_omega(w, h, r) is not None else (h, w)
            om = roll_omega(rw, rh, r)
            period = roll_period(rw, rh, r) if om is not None else float("nan")
            rows.append(
                {
                    "block": name,
                    "density_ratio": r,
                    "theory_deg": math.degrees(angle),
                    "model_deg": math.degrees(fold(theta, w == h)),
                    "theory_z": z,
                    "model_z": zm,
                    "roll_period_theory": 2 * math.pi / om if om else float("nan"),
                    "roll_period_model": period,
                }
            )
            q = rows[-1]
            print(
                f"{name:12s} r = {r:.2f}: settled {q['model_deg']:8.4f} deg (theory {q['theory_deg']:8.4f}), "
                f"z {zm:+.8f} ({z:+.8f}), roll period {period:.4f} ({q['roll_period_theory']:.4f})",
                flush=True,
            )
    write_rows(out / "floating_stability.csv", rows)
    plot(rows, out / "floating_stability.png")
    worst_deg = max(abs(q["model_deg"] - q["theory_deg"]) for q in rows)
    worst_z = max(abs(q["model_z"] - q["theory_z"]) for q in rows)
    stable = [q for q in rows if math.isfinite(q["roll_period_theory"])]
    rel = [abs(q["roll_period_model"] / q["roll_period_theory"] - 1) for q in stable]
    print(f"largest angle error {worst_deg:.2e} deg, centre height {worst_z:.2e}, roll period {max(rel):.2e} relative")


def plot(rows: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from melange_ti.testing import floating_minimum, rectangle

    fig, ax = plt.subplots(1, 2, figsize=(10, 4), constrained_layout=True)
    for k, name in enumerate(BLOCKS):
        q = [row for row in rows if row["block"] == name]
        r = [row["density_ratio"] for row in q]
        w, h = BLOCKS[name]
        # the theory at the cases' ratios, and for the square finely across its bifurcations
        curve = {row["density_ratio"]: row["theory_deg"] for row in q}
        if w == h:
            for v in np.concatenate([np.linspace(0.205, 0.3, 20), np.linspace(0.7, 0.795, 20)]):
                curve[float(v)] = math.degrees(fold(floating_minimum(rectangle(w, h), float(v), math.pi / 2, 90)[0], True))
        fine = sorted(curve)
        ax[k].plot(fine, [curve[v] for v in fine], "-", color="0.5", label="minimum of U (numpy)")
        ax[k].plot(r, [row["model_deg"] for row in q], "o", mfc="none", color="C0", label="model, settled with drag")
        ax[k].set_ylim(-3, 93 if w != h else 48)
        ax[k].ticklabel_format(useOffset=False)
        ax[k].set_title(f"{name} ({w:g} x {h:g})")
        ax[k].set_xlabel("density ratio r")
        ax[k].set_ylabel("angle from theta = 0, folded (degrees)")
        ax[k].legend(loc="upper left" if w == h else "center right", fontsize=8)
    if BLOCKS["square"][0] == BLOCKS["square"][1]:
        for x in ((3 - math.sqrt(3)) / 6, (3 + math.sqrt(3)) / 6):
            ax[0].axvline(x, color="0.8", lw=0.8, ls="--")
    fig.savefig(path, dpi=120)


if __name__ == "__main__":
    main()

"""Polygon icebergs (issue 33; the waves in test_polygon_waves.py, the bonds in test_polygon_bonds.py).

The kernels read a polygon's outline from its corners through the same clipper as a
rectangle's (:mod:`melange_ti.physics.shape.hydrostatics`); every number here is compared
with an independent numpy computation: the outline clipped by Sutherland-Hodgman
(:func:`melange_ti.geometry.below`), its area, centroid and second moments summed over
triangles from the centroid, never the model's edge-by-edge formula.
"""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest

from melange_ti.diagnostics import capsize_angle
from melange_ti.geometry import (
    MAX_VERTICES,
    area_centroid,
    below,
    outline,
    outline_problem,
    polygon_disc_local,
    polygon_discs,
    rectangle,
)
from melange_ti.model import Model
from melange_ti.scene import SceneError
from melange_ti.testing import contacts_seen, first_impulse, rotated

from .scenes import KERNEL_FORMS, make_scene
from .test_friction import MU, booked_exactly, impulse_against_the_law

TRIANGLE = np.array([[0.0, 0.0], [1.0, 0.0], [0.5, 0.8]])
PENTAGON = np.array([[0.0, 0.0], [1.2, 0.1], [1.1, 0.9], [0.4, 1.2], [-0.2, 0.5]])
RIGHT = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.3]])
TRAPEZOID = np.array([[-0.6, -0.4], [0.6, -0.4], [0.3, 0.4], [-0.3, 0.4]])
R = 0.6
DT = 0.01


def _fan(poly: np.ndarray) -> tuple[float, np.ndarray, float]:
    """Area, centroid and polar second moment about the centroid of a convex polygon, from
    the triangles of a fan (each triangle's own formulas; no Green's theorem)."""
    tris = [(poly[0], poly[k], poly[k + 1]) for k in range(1, len(poly) - 1)]
    areas = np.array([0.5 * ((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])) for a, b, c in tris])
    cents = np.array([(a + b + c) / 3.0 for a, b, c in tris])
    area = areas.sum()
    g = (areas[:, None] * cents).sum(0) / area
    # a triangle's polar moment about its own centroid: A (|a|^2 + |b|^2 + |c|^2 - 3 |centroid|^2) / 12
    polar = 0.0
    for (a, b, c), ak, ck in zip(tris, areas, cents, strict=True):
        about_own = ak * (a @ a + b @ b + c @ c - 3 * ck @ ck) / 12.0
        polar += about_own + ak * ((ck - g) @ (ck - g))
    return float(area), g, float(polar)


def _submerged(verts: np.ndarray, z: float, theta: float) -> tuple[float, float, float, np.ndarray]:
    """Area, centroid (relative to the centre of mass) and the corners of the part of the
    outline (placed with its centroid at (0, z), turned by theta) below z = 0."""
    corners = rotated(verts - _fan(verts)[1], theta) + np.array([0.0, z])
    part = below(corners, 0.0)
    if len(part) < 3:
        return 0.0, 0.0, 0.0, part
    a, xb, zb = area_centroid(part)
    return a, xb, zb - z, part


def test_the_outline_constants_against_triangles():
    """Mass, inertia, width and thickness of each outline from the corners against a fan of
    triangles; a rectangle's are the rectangle's formulas."""
    for poly in (TRIANGLE, PENTAGON, RIGHT, TRAPEZOID):
        o = outline(poly, R)
        area, g, polar = _fan(poly)
        assert o["mass"] == pytest.approx(R * area, rel=1e-14)
        assert o["inertia"] == pytest.approx(R * polar, rel=1e-12)
        np.testing.assert_allclose(o["centroid"], g, rtol=1e-13)
        assert o["bound"] == pytest.approx(np.hypot(*(poly - g).T).max(), rel=1e-14)
    o = outline(rectangle(1.0, 1.4), 0.9)
    assert o["mass"] == pytest.approx(0.9 * 1.4) and o["inertia"] == pytest.approx(0.9 * 1.4 * (1 + 1.4**2) / 12)
    assert (o["width"], o["thickness"], o["axis"]) == (1.0, 1.4, 0.0)


def test_the_principal_axis_and_the_capsize_angle():
    """A 1 x 2 rectangle's corners turned by 0.3 rad in the body frame: its principal axis is
    0.3 rad from v, and its capsize angle at tilt theta is the rectangle's at theta + 0.3;
    a square and an equilateral triangle have no principal axes (0)."""
    c, s = math.cos(0.3), math.sin(0.3)
    turned = rectangle(1.0, 2.0) @ np.array([[c, s], [-s, c]])
    o = outline(turned, 1.0)
    assert o["axis"] == pytest.approx(0.3, abs=1e-12)
    theta = np.array([0.0, 0.2, 0.5, -1.0, 2.0])
    np.testing.assert_allclose(capsize_angle(theta, np.full(5, o["axis"])), capsize_angle(theta + 0.3), atol=1e-12)
    assert outline(rectangle(1.0, 1.0), 1.0)["axis"] == 0.0
    equilateral = np.array([[0.0, 0.0], [1.0, 0.0], [0.5, math.sqrt(3) / 2]])
    assert abs(outline(equilateral, 1.0)["axis"]) < 1e-9


# ---------------------------------------------------------------- the kernels against numpy
POSES = ((-0.2, 0.0), (-0.2, 0.4), (0.1, 2.0), (-0.35, -1.1), (-3.0, 0.7), (2.0, 0.3))  # (z, theta): dry and sunk too


def test_buoyancy_force_and_torque_against_the_clipped_polygon():
    """One step from rest with gravity and buoyancy: each body's vertical acceleration is
    (A - m) / m and its angular acceleration A x_B / I, A and x_B those of the outline clipped
    at the water line in numpy; a scene of a triangle, a pentagon, a right triangle, a
    trapezoid and a rectangle by width and thickness (fewer corners than the most: the kernels
    skip the missing edges), at poses wet, crossing, sunk and dry."""
    shapes = (TRIANGLE, PENTAGON, RIGHT, TRAPEZOID, None)
    for z, theta in POSES:
        bergs = []
        for k, poly in enumerate(shapes):
            berg = {"x": 3.0 * k, "z": z, "theta": theta}
            if poly is None:
                berg.update(width=1.0, thickness=1.4)
            else:
                berg["vertices"] = poly.tolist()
            bergs.append(berg)
        m = Model(make_scene(["gravity", "buoyancy"], bergs, {"density_ratio": R}, dt=DT))
        m.advance(1)
        s = m.state()
        for k, poly in enumerate(shapes):
            verts = rectangle(1.0, 1.4) if poly is None else poly
            o = outline(verts, R)
            a, xb, _, _ = _submerged(verts, z, theta)
            assert s["vz"][k] / DT == pytest.approx((a - o["mass"]) / o["mass"], rel=1e-12, abs=1e-12), (k, z, theta)
            assert s["omega"][k] / DT == pytest.approx(a * xb / o["inertia"], rel=1e-10, abs=1e-12), (k, z, theta)


def test_the_potential_energy_against_the_clipped_polygon():
    """The sampled potential energy ``m g z - rho g int_sub z dA`` of a pentagon at several
    poses against numpy."""
    for z, theta in POSES:
        m = Model(
            make_scene(["gravity", "buoyancy"], [{"z": z, "theta": theta, "vertices": PENTAGON.tolist()}], {"density_ratio": R})
        )
        u = float(m.sample()["potential"][0])
        a, _, zb, _ = _submerged(PENTAGON, z, theta)
        assert u == pytest.approx(outline(PENTAGON, R)["mass"] * z - a * (zb + z), rel=1e-12, abs=1e-13), (z, theta)


def test_added_mass_and_form_drag_see_the_submerged_polygon():
    """The added mass and inertia the kick stores are ``C_a A`` and ``C_I J`` of the submerged
    part (J its polar moment about the centre of mass, numpy: a fan of triangles); form drag on
    a horizontal velocity divides it by ``1 + 0.5 C_d P |v| dt / (m + m_a)``, P the submerged
    part's vertical extent."""
    ca, ci, cd, vx = 0.7, 0.4, 1.3, 0.25
    for z, theta in POSES[:4]:
        bergs = [{"z": z, "theta": theta, "vx": vx, "vertices": TRIANGLE.tolist()}]
        physics = {"density_ratio": R, "added_mass": ca, "added_inertia": ci, "form_drag": cd}
        m = Model(make_scene(["added_mass", "form_drag"], bergs, physics, dt=DT))  # no force: the kick is theirs alone
        m.advance(1)
        rows = m.arrays.b.to_numpy()
        from melange_ti.physics.data.schema import Body

        _, _, _, part = _submerged(TRIANGLE, z, theta)
        area, g, polar = _fan(part)
        j = polar + area * ((g - np.array([0.0, z])) @ (g - np.array([0.0, z])))  # about the centre of mass
        assert rows[0, Body.ADDED_M] == pytest.approx(ca * area, rel=1e-12)
        assert rows[0, Body.ADDED_I] == pytest.approx(ci * j, rel=1e-10)
        p = float(part[:, 1].max() - part[:, 1].min())
        mass = outline(TRIANGLE, R)["mass"] + ca * area
        assert m.state()["vx"][0] == pytest.approx(vx / (1.0 + 0.5 * cd * p / mass * vx * DT), rel=1e-13)


def test_a_rectangle_by_its_corners_is_the_rectangle():
    """The paper's block given by its four corners follows the block given by width and
    thickness (the polygon path against the rectangle path) over 500 steps, to rounding."""
    start = {"x": 0.0, "z": -0.3, "theta": 0.3, "omega": 0.1}
    physics = {"density_ratio": 0.9, "drag": 0.1, "angular_drag": 0.1}
    a = Model(make_scene(["gravity", "buoyancy", "drag"], [{**start, "width": 1.0, "thickness": 1.4}], physics))
    b = Model(make_scene(["gravity", "buoyancy", "drag"], [{**start, "vertices": rectangle(1.0, 1.4).tolist()}], physics))
    assert a.fx.vertices == 0 and b.fx.vertices == 4
    a.advance(500)
    b.advance(500)
    for k in ("x", "z", "theta", "vz", "omega"):
        np.testing.assert_allclose(b.state()[k], a.state()[k], rtol=1e-11, atol=1e-13)


@pytest.mark.parametrize("mode,islands,groups", KERNEL_FORMS[1:2])
def test_polygons_in_every_form_give_the_same_bits(mode, islands, groups):
    """Three polygons with drag, form drag and added mass: the parallel form's state equals
    the serial form's bit for bit."""
    bergs = [
        {"x": 3.0 * k, "z": -0.3, "theta": 0.2 * k, "vertices": p.tolist()} for k, p in enumerate((TRIANGLE, PENTAGON, RIGHT))
    ]
    effects = ["gravity", "buoyancy", "drag", "form_drag", "added_mass"]
    sc = make_scene(effects, bergs, {"density_ratio": R, "form_drag": 1.0, "added_mass": 0.5, "added_inertia": 0.5})
    one = Model(sc, mode="serial")
    two = Model(sc, mode=mode, islands=islands, groups=groups)
    one.advance(300)
    two.advance(300)
    for k, v in one.state().items():
        assert np.array_equal(v, two.state()[k]), k


# ---------------------------------------------------------------- scenes
BAD = {
    "clockwise": ([[0, 0], [0.5, 0.8], [1, 0]], "clockwise"),
    "not convex": ([[0, 0], [1, 0], [1, 1], [0.8, 0.2], [0, 1]], "not convex"),
    "in a line": ([[0, 0], [0.5, 0], [1, 0], [0.5, 1]], "not convex"),
    "too few": ([[0, 0], [1, 0]], "3 to"),
    "too many": ([[math.cos(t), math.sin(t)] for t in np.linspace(0, 2 * math.pi, MAX_VERTICES + 2)[:-1]], "3 to"),
    "crossing": ([[0, 0], [1, 1], [1, 0], [0, 1]], "crosses itself"),
    "no area": ([[0, 0], [1, 0], [2, 0]], "no area"),
    "repeated": ([[0, 0], [1, 0], [1, 0], [0, 1]], "repeats a corner"),
    "not pairs": ([[0, 0, 1], [1, 0, 1], [0, 1, 1]], "[x, z] corners"),
}


@pytest.mark.parametrize("name", sorted(BAD))
def test_a_bad_outline_is_refused_naming_it(name):
    vertices, words = BAD[name]
    assert words in outline_problem(vertices)
    with pytest.raises(SceneError, match=r"iceberg\[1\]\.vertices = .*" + words.replace("[", r"\[").replace("]", r"\]")):
        make_scene(["gravity", "buoyancy"], [{"x": -5.0}, {"vertices": vertices}], {})


def test_an_outline_with_width_is_refused_and_every_effect_takes_polygons(tmp_path):
    with pytest.raises(SceneError, match=r"iceberg\[0\]\.vertices = .*leave out width and thickness"):
        make_scene(["gravity", "buoyancy"], [{"vertices": TRIANGLE.tolist(), "width": 1.0}], {})
    with pytest.raises(SceneError, match=r"contacts\.discs = 8: too few for iceberg 0's outline"):
        make_scene(["collisions"], [{"vertices": [[0, 0], [3, 0], [3, 0.05], [0, 0.05]]}], {}, contacts={"discs": 8})
    scene = tmp_path / "s.toml"
    scene.write_text(
        '[scene]\neffects = ["gravity", "buoyancy", "collisions", "bonds"]\n'
        "[[iceberg]]\nx = 3.0\nwidth = 1.0\nvertices = [[0, 0], [1, 0], [0.5, 0.8]]\n"
    )
    r = subprocess.run([sys.executable, "-m", "melange_ti", "check", str(scene)], capture_output=True, text=True)
    assert r.returncode == 2 and "Traceback" not in r.stderr and len(r.stderr.strip().splitlines()) == 1
    assert "iceberg[0].vertices" in r.stderr and "width" in r.stderr
    scene.write_text(scene.read_text().replace("width = 1.0\n", ""))  # the bonds take polygons
    r = subprocess.run([sys.executable, "-m", "melange_ti", "check", str(scene)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    scene.write_text(scene.read_text().replace('"collisions", "bonds"', '"waves"'))  # as do the waves
    r = subprocess.run([sys.executable, "-m", "melange_ti", "check", str(scene)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr


def test_an_outline_is_placed_by_its_centroid_and_kept_in_the_run_file(tmp_path):
    """The corners as written fix shape and orientation; the centroid sits at the iceberg's x,
    z. The run file holds the outlines (netCDF dimension ``corner``), and a ``[start]`` from it
    continues the run bit for bit; capsized_fraction measures a polygon by its principal axis."""
    import melange_ti as mt
    from melange_ti.io.hdf5 import read_run

    # a 1 x 2 block whose corners are turned by 30 degrees in the body frame: at theta = 0.3 rad
    # (17 degrees) its long axis is 47 degrees from vertical, so it counts as capsized at once
    c, s = math.cos(math.radians(30)), math.sin(math.radians(30))
    turned = (rectangle(1.0, 2.0) @ np.array([[c, s], [-s, c]]) + 7.0).tolist()  # written about another origin
    text = (
        '[scene]\neffects = ["gravity", "buoyancy", "drag"]\n[time]\nduration = 4.0\n'
        "[output]\nsnapshot_interval = 2.0\ndiagnostic_interval = 1.0\n"
        f"[[iceberg]]\nx = 1.0\nz = -0.2\ntheta = 0.1\nvertices = {TRIANGLE.tolist()}\n"
        f"[[iceberg]]\nx = 5.0\nz = -0.4\ntheta = 0.3\nvertices = {turned}\n"
        "[[iceberg]]\nx = 9.0\nz = -0.3\nwidth = 1.0\nthickness = 1.4\n"
    )
    (tmp_path / "a.toml").write_text(text)
    mt.run(mt.load_scene(tmp_path / "a.toml"), tmp_path / "a.h5")
    run = read_run(tmp_path / "a.h5")
    assert run["snapshots"]["x"][0].tolist() == [1.0, 5.0, 9.0] and run["snapshots"]["z"][0].tolist() == [-0.2, -0.4, -0.3]
    g = run["icebergs"]
    assert g["corners"].tolist() == [3, 4, 4]
    np.testing.assert_allclose(g["corner_u"][0, :3], TRIANGLE[:, 0] - 0.5, atol=1e-15)
    np.testing.assert_allclose(g["corner_v"][2], [-0.7, 0.7, 0.7, -0.7])
    assert g["axis"][1] == pytest.approx(math.radians(30), abs=1e-12)
    assert run["diagnostics"]["capsized_fraction"][0] == pytest.approx(1 / 3)
    tree = mt.open_run(tmp_path / "a.h5")
    assert tree["icebergs"]["corner_u"].dims == ("iceberg", "corner")
    (tmp_path / "b.toml").write_text(
        '[scene]\neffects = ["gravity", "buoyancy", "drag"]\n[time]\nduration = 2.0\n'
        '[output]\nsnapshot_interval = 2.0\n[start]\nfile = "a.h5"\ntime = 2.0\n'
    )
    mt.run(mt.load_scene(tmp_path / "b.toml"), tmp_path / "b.h5")
    again = read_run(tmp_path / "b.h5")
    for k in ("x", "z", "theta", "vx", "vz", "omega"):
        assert np.array_equal(again["snapshots"][k][-1], run["snapshots"][k][-1]), k
    np.testing.assert_array_equal(again["icebergs"]["corner_u"], g["corner_u"])


# ---------------------------------------------------------------- contacts
def test_the_disc_layout_of_a_polygon():
    """Every disc centre lies at least the radius inside every edge and exactly the radius
    inside the edge it sits on (so the union touches each face); each corner's disc touches
    both faces that meet there; no two neighbours on an edge are farther apart than
    spacing * r; at most ``discs`` of them."""
    for poly in (TRIANGLE, PENTAGON, RIGHT, TRAPEZOID, rectangle(1.0, 1.4)):
        corners = poly - _fan(poly)[1]
        k = len(corners)
        edge = np.roll(corners, -1, 0) - corners
        inward = np.stack([-edge[:, 1], edge[:, 0]], -1) / np.hypot(edge[:, 0], edge[:, 1])[:, None]
        for discs, spacing in ((12, 2.0), (32, 2.0), (32, 1.5)):
            r, q, n = polygon_discs(corners, discs, spacing)
            assert r > 0 and n.sum() <= discs and n.min() >= 1
            for e in range(k):
                a, b = q[e], q[(e + 1) % k]
                assert np.hypot(*(b - a)) / n[e] <= spacing * r * (1 + 1e-9)
                for j in range(n[e]):
                    depth = np.einsum("kd,kd->k", a + (j / n[e]) * (b - a) - corners, inward)  # inside each edge's line
                    assert depth.min() >= r * (1 - 1e-9) and depth[e] == pytest.approx(r, rel=1e-9)
                assert float((a - corners[e - 1]) @ inward[e - 1]) == pytest.approx(r, rel=1e-9)  # the corner's disc


def _pair_scene(e):
    """A triangle's corner into a trapezoid's slanted face, far from everything else."""
    bergs = [
        {"x": 40.0, "z": 10.25, "theta": 0.5, "vertices": TRIANGLE.tolist()},
        {"x": 41.4, "z": 10.0, "theta": 0.0, "vertices": TRAPEZOID.tolist()},
    ]
    physics = {"restitution": e, "density_ratio": R, "friction": MU}
    return make_scene(["collisions", "friction"], bergs, physics, contacts={"discs": 32})


def _discs_world(m, s, q, x):
    k = m.constants()
    corners = np.stack([k["corner_u"][q], k["corner_v"][q]], -1)[: k["corners"][q]]
    local, r = polygon_disc_local(corners, 32)
    c, sn = math.cos(s["theta"][q]), math.sin(s["theta"][q])
    return np.stack([x + local[:, 0] * c - local[:, 1] * sn, s["z"][q] + local[:, 0] * sn + local[:, 1] * c], -1), r


def _touching(m, gap=0.02):
    """The model's state with the triangle moved right until its discs are ``gap`` from the
    trapezoid's (numpy, bisection)."""
    s = {key: v.copy() for key, v in m.state().items()}
    other, rj = _discs_world(m, s, 1, s["x"][1])
    lo, hi = s["x"][0] - 3.0, s["x"][1]  # far apart, and overlapping
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        mine, ri = _discs_world(m, s, 0, mid)
        d = np.linalg.norm(mine[:, None, :] - other[None, :, :], axis=-1).min() - ri - rj
        lo, hi = (mid, hi) if d > gap else (lo, mid)
    s["x"][0] = lo
    return s


@pytest.mark.parametrize("e", [0.5, 1.0])
def test_oblique_impact_of_two_polygons_against_the_law(e):
    """The triangle's corner strikes the trapezoid's slanted face (its normal 20.6 degrees
    from horizontal), closing at speed 2 while sliding past at five speeds: each impulse is
    the coupled law's, with restitution and Coulomb friction, at the contact found (equal and
    opposite, v_n' = -e v_n, the ledgers exact), momentum and angular momentum kept; the
    contact lies on the slanted face."""
    sc = _pair_scene(e)
    m = Model(sc)
    k = m.constants()
    mass, inertia = k["mass"], k["inertia"]
    top, bottom = TRAPEZOID[3], TRAPEZOID[0]  # the left, slanted face
    face = bottom - top
    outward = np.array([face[1], -face[0]]) / np.hypot(*face)  # the trapezoid's, into the triangle
    assert outward[0] < 0 and abs(math.degrees(math.atan2(outward[1], -outward[0])) - 20.556) < 0.01
    radius = [_discs_world(m, m.state(), q, 0.0)[1] for q in (0, 1)]
    regimes = set()
    for slide in (-3.0, -0.4, 0.1, 0.5, 3.0):
        s = _touching(m)
        share = mass[1] / (mass[0] + mass[1])
        s["vx"][0], s["vx"][1] = 2.0 * share, -2.0 * (1.0 - share)
        s["vz"][0], s["vz"][1] = slide * share, -slide * (1.0 - share)
        s["omega"][:] = 0.0
        m.set_state(s)
        b, a, tb, ta = first_impulse(m)
        (c,) = contacts_seen(m)
        # on the slanted face: within a disc radius of its line (the point lies between the two
        # discs' surfaces, a disc radius inside the face at most), between its ends
        centre = np.array([b["x"][1], b["z"][1]])
        across = float((c.p - centre - top) @ outward)
        along = float((c.p - centre - top) @ face) / float(face @ face)
        assert (c.i, c.j) == (0, 1) and abs(across) < radius[1] and 0.0 < along < 1.0, (c.p, across, along)
        regime, jn, jt, vn, vt, vn_after, vt_after, kk = impulse_against_the_law(m, b, a, e, moving={0, 1})
        assert abs(kk[0, 1]) > 0.05 * kk[0, 0], f"an off-centre contact: K = {kk}"
        booked_exactly(b, a, tb, ta, (0, 1), mass, inertia, jn, jt, vn, vt, vn_after, vt_after)
        momentum = [sum(mass[q] * st[v][q] for q in (0, 1)) for st in (b, a) for v in ("vx", "vz")]
        assert momentum[2] == pytest.approx(momentum[0], abs=1e-13) and momentum[3] == pytest.approx(momentum[1], abs=1e-13)
        spin = [
            sum(mass[q] * (b["x"][q] * st["vz"][q] - b["z"][q] * st["vx"][q]) + inertia[q] * st["omega"][q] for q in (0, 1))
            for st in (b, a)
        ]
        assert spin[1] == pytest.approx(spin[0], abs=1e-11)
        regimes.add(regime)
    assert regimes == {"stick", "slide"}, regimes


def test_a_polygon_into_the_wall_against_the_law():
    """The pentagon's corner into the wall at v_x = -1, sliding slowly and fast: the coupled
    law's impulse at the wall's contact, both regimes, the ledgers exact."""
    bergs = [{"x": 0.0, "z": 3.0, "theta": 0.3, "vertices": PENTAGON.tolist()}]
    physics = {"restitution": 0.5, "density_ratio": R, "friction": MU, "wall_x": -50.0}
    m = Model(make_scene(["collisions", "wall", "friction"], bergs, physics, contacts={"discs": 32}))
    k = m.constants()
    regimes = set()
    for vz in (-0.1, 3.0):
        s = {key: v.copy() for key, v in m.state().items()}
        s["theta"][0], s["omega"][0] = 0.3, 0.0
        discs, r = _discs_world(m, s, 0, 0.0)
        s["x"][0], s["vx"][0], s["vz"][0] = -50.0 - (discs[:, 0].min() - r) + 0.015, -1.0, vz
        m.set_state(s)
        b, a, tb, ta = first_impulse(m)
        regime, jn, jt, vn, vt, vn_after, vt_after, _ = impulse_against_the_law(m, b, a, 0.5, moving={0})
        booked_exactly(b, a, tb, ta, (0,), k["mass"], k["inertia"], jn, jt, vn, vt, vn_after, vt_after)
        regimes.add(regime)
    assert regimes == {"stick", "slide"}, regimes


@pytest.mark.parametrize("form", KERNEL_FORMS[2:], ids=lambda f: f"{f[0]}-islands{f[1]}-groups{f[2]}")
def test_a_jostling_row_of_polygons_gives_the_same_bits_in_every_form(form):
    """Eight fragments of four shapes side by side with gravity, buoyancy, drag, contacts, the
    wall and friction, thrown into each other: the parallel forms' state (groups, islands)
    equals the serial form's bit for bit after 400 steps, and they did collide."""
    shapes = (TRAPEZOID, TRIANGLE, PENTAGON, RIGHT)
    bergs = [
        {"x": 1.0 + 1.45 * q, "z": -0.25, "theta": 0.3 * (-1) ** q, "vx": 0.6 * (-1) ** q, "vertices": shapes[q % 4].tolist()}
        for q in range(8)
    ]
    effects = ["gravity", "buoyancy", "drag", "collisions", "wall", "friction"]
    sc = make_scene(effects, bergs, {"density_ratio": R, "friction": MU, "wall_x": 0.0}, contacts={"discs": 24})
    one = Model(sc, mode="serial")
    mode, islands, groups = form
    two = Model(sc, mode=mode, islands=islands, groups=groups)
    one.advance(400)
    two.advance(400)
    assert one.totals().impulses >= 4  # each of the four approaching pairs met
    for key, v in one.state().items():
        assert np.array_equal(v, two.state()[key]), key


# ---------------------------------------------------------------- a shelf cut by tilted faces
def test_a_shelf_with_tilted_cuts_packs_and_floats():
    """``shelf.cut_tilt_std``: each cut is shared, the right face of iceberg k parallel to the
    left face of k + 1 (its tilt drawn after everything else, so the tilts of the icebergs are
    those of the vertical-cut shelf), the shelf's two ends vertical; at the water line the
    faces are ``gap`` apart less what floating each iceberg moved them along their slant,
    ``tan(alpha) (delta_k+1 - delta_k)``; each iceberg floats upright with ``density_ratio``
    of its area submerged (numpy clipping)."""
    from melange_ti import scene
    from melange_ti.scene.initial import equilibrium_z

    r, gap, count = 0.8946, 0.1, 30
    plain = scene.load(None, overrides=[("shelf.count", count)]).icebergs()
    cut = scene.load(None, overrides=[("shelf.count", count), ("shelf.cut_tilt_std", 0.1)]).icebergs()
    assert plain.outline is None and np.array_equal(cut.theta, plain.theta)
    world = cut.outline + np.stack([cut.x, cut.z], -1)[:, None, :]  # at theta = 0
    built = equilibrium_z(1.4, r, 0.0) + 0.7  # every top before floating
    delta = world[:, 1, 1] - built  # how far floating moved each iceberg up
    assert world[0, 2, 0] == world[0, 3, 0] and world[-1, 0, 0] == world[-1, 1, 0]
    slopes = []
    for k in range(count - 1):
        right = world[k, 1] - world[k, 0]
        left = world[k + 1, 2] - world[k + 1, 3]
        assert abs(right[0] * left[1] - right[1] * left[0]) < 1e-12 * np.hypot(*right) * np.hypot(*left)
        tan = right[0] / right[1]
        at = [w[0] + (0.0 - w[1]) * tan for w in (world[k, 0], world[k + 1, 3])]  # both faces at z = 0
        assert at[1] - at[0] == pytest.approx(gap - tan * (delta[k + 1] - delta[k]), abs=1e-12)
        slopes.append(tan)
    assert 0.05 < np.std(np.arctan(slopes)) < 0.2  # a spread of about 0.1 rad
    for k in range(count):
        corners = world[k, : cut.corners[k]]
        part = below(corners, 0.0)
        assert area_centroid(part)[0] == pytest.approx(r * area_centroid(corners)[0], rel=1e-12)


@pytest.mark.parametrize(
    "text, said",
    [
        ("count = 400\ncut_tilt_std = 0.6\n", ("shelf.cut_tilt_std = 0.6", "use a smaller spread")),
        ("cut_tilt = 0.7\n", ("shelf.cut_tilt = 0.7", "[-0.5, 0.5]")),
    ],
)
def test_a_shelf_cut_too_steeply_is_refused(tmp_path, text, said):
    scene = tmp_path / "s.toml"
    scene.write_text("[shelf]\n" + text)
    r = subprocess.run([sys.executable, "-m", "melange_ti", "check", str(scene)], capture_output=True, text=True)
    assert r.returncode == 2 and "Traceback" not in r.stderr and len(r.stderr.strip().splitlines()) == 1
    assert all(part in r.stderr for part in said)


def test_a_shelf_cut_at_one_tilt_is_a_row_of_parallelograms():
    """``shelf.cut_tilt`` alone: every cut leans by the same angle (its top to +x for a
    positive tilt), so every iceberg between two cuts is a parallelogram of the shelf's width
    and thickness (area w h, horizontal offset h tan(alpha) between its top and bottom), the
    two ends trapezoids with one vertical face; no random number is drawn for the cuts, so
    the tilts are the vertical shelf's, and a spread about the mean moves the mean."""
    from melange_ti import scene

    alpha, count = math.radians(20.0), 12
    plain = scene.load(None, overrides=[("shelf.count", count)]).icebergs()
    cut = scene.load(None, overrides=[("shelf.count", count), ("shelf.cut_tilt", alpha)]).icebergs()
    assert np.array_equal(cut.theta, plain.theta)
    world = cut.outline + np.stack([cut.x, cut.z], -1)[:, None, :]
    for k in range(1, count - 1):
        c = world[k]
        for right, left in ((c[1] - c[0], c[2] - c[3]),):
            assert right[0] / right[1] == pytest.approx(math.tan(alpha), rel=1e-12)  # the top leans to +x
            assert left[0] / left[1] == pytest.approx(math.tan(alpha), rel=1e-12)
        assert c[0, 0] - c[3, 0] == pytest.approx(1.0, abs=1e-12) and c[1, 0] - c[2, 0] == pytest.approx(1.0, abs=1e-12)
        assert area_centroid(c)[0] == pytest.approx(1.4, rel=1e-12)  # base w times height h
    assert world[0, 2, 0] == world[0, 3, 0] and world[-1, 0, 0] == world[-1, 1, 0]
    spread = scene.load(
        None, overrides=[("shelf.count", 400), ("shelf.cut_tilt", alpha), ("shelf.cut_tilt_std", 0.02)]
    ).icebergs()
    w = spread.outline
    slopes = np.arctan((w[:-1, 1, 0] - w[:-1, 0, 0]) / (w[:-1, 1, 1] - w[:-1, 0, 1]))
    assert abs(np.mean(slopes) - alpha) < 4 * 0.02 / math.sqrt(399) and 0.015 < np.std(slopes) < 0.025

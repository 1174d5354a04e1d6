"""Polygon icebergs (issue 33, first slice: gravity, buoyancy, drag, form drag, added mass).

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
from melange_ti.geometry import MAX_VERTICES, area_centroid, below, outline, outline_problem, rectangle
from melange_ti.model import Model
from melange_ti.scene import SceneError
from melange_ti.testing import rotated

from .scenes import KERNEL_FORMS, make_scene

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
    # a triangle's polar moment about its centroid: A (|a|^2 + |b|^2 + |c|^2 - 3 |centroid|^2) / 6 ... about 0
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


def test_an_outline_with_width_or_an_effect_it_lacks_is_refused(tmp_path):
    with pytest.raises(SceneError, match=r"iceberg\[0\]\.vertices = .*leave out width and thickness"):
        make_scene(["gravity", "buoyancy"], [{"vertices": TRIANGLE.tolist(), "width": 1.0}], {})
    with pytest.raises(SceneError, match=r"iceberg\[0\]\.vertices = .*names collisions"):
        make_scene(["gravity", "buoyancy", "collisions"], [{"vertices": TRIANGLE.tolist()}], {})
    scene = tmp_path / "s.toml"
    scene.write_text(
        '[scene]\neffects = ["gravity", "buoyancy", "wall"]\n[[iceberg]]\nx = 3.0\nvertices = [[0, 0], [1, 0], [0.5, 0.8]]\n'
    )
    r = subprocess.run([sys.executable, "-m", "melange_ti", "check", str(scene)], capture_output=True, text=True)
    assert r.returncode == 2 and "Traceback" not in r.stderr and len(r.stderr.strip().splitlines()) == 1
    assert "iceberg[0].vertices" in r.stderr and "wall" in r.stderr


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

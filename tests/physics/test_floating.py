"""Floating stability against theory (issue 33; validation/floating_stability.py sweeps more):
a lone square, and polygons (triangles, a pentagon), settle with drag to the orientation and
draft of the global minimum of their potential energy, computed in numpy
(:func:`melange_ti.testing.floating_minimum`), whether that is flat, tilted or corner-up; the
numpy minimum itself against the closed-form results; the polygons' (heave, roll) stiffness
against the potential's Hessian and their small roll period against it (the script's theory,
its shapes and its roll measurement are used here)."""

from __future__ import annotations

import importlib.util
import math

import numpy as np
import pytest

from melange_ti.model import Model
from melange_ti.scene.initial import equilibrium_z
from melange_ti.testing import floating, floating_minimum, make_scene, rectangle

from ..conftest import ROOT

_spec = importlib.util.spec_from_file_location("floating_stability", ROOT / "validation" / "floating_stability.py")
fs = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(fs)

SQUARE = rectangle(1.0, 1.0)
FLAT_LIMIT = (3 - math.sqrt(3)) / 6  # a square floats flat only below this density ratio (or above 1 minus it)


def fold(theta: float) -> float:
    """The square's angle from the nearest flat position, in [0, pi/4]."""
    return abs((theta + math.pi / 4) % (math.pi / 2) - math.pi / 4)


def test_the_numpy_minimum_against_closed_forms():
    """Flat below (3 - sqrt 3) / 6, where the metacentric height 1/(12 r) + r/2 - 1/2 turns
    positive, tilted just above it, corner-up at r = 1/2 (its centre at the water line),
    and the draft of a flat square r."""
    for r in (0.1, 0.2, 0.8, 0.9):
        theta, z = floating_minimum(SQUARE, r, math.pi / 2, 180)
        assert fold(theta) < 1e-9 and z == pytest.approx(0.5 - r, abs=1e-12), r
    theta, z = floating_minimum(SQUARE, 0.5, math.pi / 2, 180)
    assert fold(theta) == pytest.approx(math.pi / 4, abs=1e-9) and abs(z) < 1e-12
    theta, _ = floating_minimum(SQUARE, FLAT_LIMIT + 0.01, math.pi / 2, 180)
    assert 0.05 < fold(theta) < math.pi / 4 - 0.05
    # the flat position is a stationary point whose curvature changes sign at the limit
    for r, sign in ((FLAT_LIMIT - 0.01, 1), (FLAT_LIMIT + 0.01, -1)):
        u = [floating(SQUARE, r, t)[0] for t in (-1e-3, 0.0, 1e-3)]
        assert sign * (u[0] + u[2] - 2 * u[1]) > 0, r


@pytest.mark.parametrize("r", [0.15, 0.22, 0.5, 0.77, 0.85])
def test_a_square_settles_at_the_minimum_of_its_potential(r):
    """From a flat position tilted by 0.05 rad, with drag 0.5 to t = 300: the angle within
    0.5 degrees and the centre's height within 1e-6 of the numpy minimum."""
    bergs = [{"x": 0.0, "z": equilibrium_z(1.0, r, 0.0), "theta": 0.05, "width": 1.0, "thickness": 1.0}]
    physics = {"density_ratio": r, "drag": 0.5, "angular_drag": 0.5, "wall_x": -50.0}
    m = Model(make_scene(["gravity", "buoyancy", "drag"], bergs, physics))
    m.advance(30_000)
    s = m.state()
    theta, z = floating_minimum(SQUARE, r, math.pi / 2, 180)
    assert math.degrees(abs(fold(float(s["theta"][0])) - fold(theta))) < 0.5, (s["theta"][0], theta)
    assert abs(float(s["z"][0]) - z) < 1e-6, (s["z"][0], z)
    assert np.max(np.abs([s["vx"][0], s["vz"][0], s["omega"][0]])) < 1e-9  # settled


@pytest.mark.parametrize("name", list(fs.SHAPES))
def test_the_polygon_stiffness_is_the_potentials_hessian(name):
    """``K_zz = L, K_ztheta = L d, K_thetatheta = V GM + L d^2`` (z: the centre's height, x
    free) against central differences of the numpy potential, at the floating draft of
    arbitrary orientations (the derivation does not need an equilibrium); eliminating the
    heave leaves ``V GM``, the curvature of the potential at the floating draft."""
    p, _ = fs.outline(name)
    for r in (0.35, 0.8):
        for theta in (0.3, 2.0, 4.4):
            h = fs.hydrostatics(p, r, theta)
            k = fs.fd_hessian(p, r, h["z"], theta)
            assert np.abs(h["K"] - k).max() < 1e-6 * np.abs(h["K"]).max(), (r, theta, h["K"], k)
            e = 1e-3
            u = [floating(p, r, theta + s)[0] for s in (-e, 0.0, e)]
            assert (u[0] + u[2] - 2 * u[1]) / e**2 == pytest.approx(h["V"] * h["GM"], rel=1e-4), (r, theta)


@pytest.mark.parametrize(
    ("name", "r"), [("equilateral triangle", 0.45), ("right triangle", 0.2), ("pentagon", 0.35), ("pentagon", 0.8)]
)
def test_a_polygon_settles_at_the_minimum_of_its_potential(name, r):
    """From rest 0.1 rad off the global minimum (inside its basin: its energy below the lower
    neighbouring barrier), at its floating draft, with drag 0.5 to t = 100 (the script finds
    every case inside the bounds by t = 40): the angle within 0.5 degrees (modulo the shape's
    symmetry) and the centre's height within 1e-6 of the numpy minimum. The corners are given
    off their centroid, as a user would; the model puts the centroid at x, z. The triangle at
    0.45 floats tilted, neither vertex up nor down (between r = 7/16 and 9/16)."""
    p, period = fs.outline(name)
    theta, z = floating_minimum(p, r, period, 360)
    assert fs.below_barrier(p, r, theta, theta + 0.1) < 1
    bergs = [
        {"x": 0.0, "z": floating(p, r, theta + 0.1)[1], "theta": theta + 0.1, "vertices": [list(v) for v in fs.SHAPES[name][0]]}
    ]
    physics = {"density_ratio": r, "drag": 0.5, "angular_drag": 0.5, "wall_x": -50.0}
    m = Model(make_scene(["gravity", "buoyancy", "drag"], bergs, physics))
    m.advance(10_000)
    s = m.state()
    assert math.degrees(abs(fs.wrap(float(s["theta"][0]) - theta, period))) < 0.5, (s["theta"][0], theta)
    assert abs(float(s["z"][0]) - z) < 1e-6, (s["z"][0], z)
    assert np.max(np.abs([s["vx"][0], s["vz"][0], s["omega"][0]])) < 1e-9  # settled


@pytest.mark.parametrize(("name", "r"), [("trapezoid", 0.35), ("right triangle", 0.8)])
def test_a_polygons_small_roll_period(name, r):
    """Without drag, started in the roll mode 1e-3 rad off the floating position: the period
    from zero crossings over about eight periods within 1% of ``2 pi / omega`` from
    ``det(K - omega^2 M) = 0``. The trapezoid floats symmetric (d = 0: ``I omega^2 = m g GM``);
    the right triangle's water line is off its centre of mass (d = 0.1), where the decoupled
    formula is off by more than 10%."""
    p, period = fs.outline(name)
    theta, _ = floating_minimum(p, r, period, 360)
    mode = fs.roll_mode(p, r, theta)
    assert (abs(mode["d"]) < 1e-9) == (name == "trapezoid")
    if name == "right triangle":
        assert abs(mode["omega_decoupled"] / mode["omega"] - 1) > 0.1
    assert fs.polygon_roll_period(name, r, theta, mode) == pytest.approx(2 * math.pi / mode["omega"], rel=0.01)


def test_icebergs_given_without_z_float_at_their_tilt():
    """Issue 47: icebergs given one by one were not floated (z left out meant z = 0). Left out,
    or "float", z is now the height at which the outline, at its tilt, displaces
    density_ratio of its area in still water: an upright rectangle at the shelf's exact
    equilibrium_z, any other outline where the numpy clipping of testing.floating puts it;
    the model's own hydrostatics then holds each in heave (its first kick leaves vz at
    rounding). A given z is kept, and the resolved scene says "float", so it reloads the same."""
    from melange_ti import scene
    from melange_ti.scene import DENSITY_RATIO as R

    triangle = [[0.0, 0.0], [1.0, 0.0], [0.5, 0.8]]
    pentagon = [[0.0, 0.0], [1.2, 0.1], [1.1, 0.9], [0.4, 1.4], [-0.2, 0.5]]
    bergs = (
        "[[iceberg]]\nx = 0.0\n"  # upright rectangle, z left out
        '[[iceberg]]\nx = 3.0\ntheta = 0.3\nz = "float"\n'
        f"[[iceberg]]\nx = 6.0\ntheta = 0.5\nvertices = {triangle}\n"
        f'[[iceberg]]\nx = 9.0\ntheta = -0.4\nz = "float"\nvertices = {pentagon}\n'
        "[[iceberg]]\nx = 12.0\nz = -0.3\n"
    )
    text = '[scene]\neffects = ["gravity", "buoyancy"]\n[physics]\nwater_level = 0.25\n[time]\ndt = 0.01\n' + bergs
    sc = scene.loads(text)
    b = sc.icebergs()
    level = 0.25
    assert b.z[0] == equilibrium_z(1.4, R, level)
    for i, theta in ((1, 0.3), (2, 0.5), (3, -0.4)):
        poly = b.outline[i, : b.corners[i]]
        assert b.z[i] == pytest.approx(level + floating(poly, R, theta)[1], abs=1e-12), i
    assert b.z[4] == -0.3
    again = scene.loads(sc.to_toml()).icebergs()
    assert np.array_equal(again.z, b.z) and sc.to_toml().count('z = "float"') == 4
    m = Model(sc)
    m.advance(1)
    vz = m.state()["vz"]
    assert np.all(np.abs(vz[:4]) < 1e-11), vz  # in balance in heave (the tilted ones roll)
    assert vz[4] < -1e-6  # the one given z = -0.3, above its draft (-0.302 here), sinks

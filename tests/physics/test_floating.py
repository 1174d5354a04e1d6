"""Floating stability against theory (issue 33; validation/floating_stability.py sweeps more):
a lone square settles, with drag, to the orientation and draft of the global minimum of its
potential energy, computed in numpy (:func:`melange_ti.testing.floating_minimum`), whether
that is flat, tilted or corner-up; the numpy minimum itself against the closed-form results."""

from __future__ import annotations

import math

import numpy as np
import pytest

from melange_ti.model import Model
from melange_ti.scene.initial import equilibrium_z
from melange_ti.testing import floating, floating_minimum, make_scene, rectangle

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

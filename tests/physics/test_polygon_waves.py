"""Polygons in waves: the waves' strips of a polygon from the shape module's clipper, against
independent numpy clipping, and the kernel forms bit for bit (the energy budget of a polygon
capsizing in waves is in test_waves_budget.py).

With ``U = rho g sum_q eta^P_q A_q`` (``A_q`` the iceberg's area below the still water line
in strip q of the grid, ``eta^P_q`` the pressure surface read at the strip's centre) the wave
kicks an iceberg with ``-grad U`` over its pose (``x``, ``z``, ``theta`` about its centre of
mass) once per wave step, and puts what it displaces into the water. Here ``A_q`` is clipped
in numpy (half-plane by half-plane, this file's own code) and ``-grad U`` taken by central
differences; the model's kick is read off the velocities of one step with and without a
surface. A rectangle among the polygons checks the reference against the rectangles' path,
whose bits are those of every wave run before polygons.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from melange_ti.geometry import outline
from melange_ti.model import Model
from melange_ti.physics.effects.waves import SUB, Wave
from melange_ti.testing import rotated

from .scenes import KERNEL_FORMS, make_scene
from .test_polygons import PENTAGON, TRAPEZOID, TRIANGLE

R = 0.6
DT = 0.01
GRID = {"water_depth": 4.0, "wave_dx": 0.25, "wave_end": 30.0, "wave_sponge": 0.0, "wave_pressure_depth": 0.0}
SHAPES = (TRIANGLE, PENTAGON, TRAPEZOID, None)  # None: a 1 x 1.4 rectangle by width and thickness
POSES = ((-0.15, 0.3), (0.05, -2.2), (-0.3, 1.1))  # (z, theta): each crossing the water line


def _clip(poly: np.ndarray, normal: np.ndarray, limit: float) -> np.ndarray:
    """The part of a convex polygon where ``normal . p <= limit`` (one Sutherland-Hodgman pass)."""
    out = []
    for k in range(len(poly)):
        p, q = poly[k], poly[(k + 1) % len(poly)]
        dp, dq = normal @ p - limit, normal @ q - limit
        if dp <= 0:
            out.append(p)
        if (dp < 0 < dq) or (dq < 0 < dp):
            out.append(p + dp / (dp - dq) * (q - p))
    return np.array(out).reshape(-1, 2)


def _area(poly: np.ndarray) -> float:
    if len(poly) < 3:
        return 0.0
    x, z = poly[:, 0], poly[:, 1]
    return 0.5 * float(np.sum(x * np.roll(z, -1) - np.roll(x, -1) * z))


def _strip_areas(corners: np.ndarray, pose: np.ndarray, x0: float, ds: float, strips: int) -> np.ndarray:
    """``A_q``: the outline (body-frame corners about its centre of mass) at ``pose`` (x, z,
    theta), below z = 0, in each strip [x0 + q ds, x0 + (q + 1) ds]."""
    world = rotated(corners, pose[2]) + pose[:2]
    wet = _clip(world, np.array([0.0, 1.0]), 0.0)
    out = np.zeros(strips)
    for q in range(strips):
        piece = _clip(_clip(wet, np.array([1.0, 0.0]), x0 + (q + 1) * ds), np.array([-1.0, 0.0]), -(x0 + q * ds))
        out[q] = _area(piece)
    return out


def _eta_at_strips(eta_p: np.ndarray) -> np.ndarray:
    """The pressure surface at each strip's centre: linear between cell centres, the end cells'
    values beyond the first and last centres."""
    m = len(eta_p)
    centres = (np.arange(m * SUB) + 0.5) / SUB - 0.5  # in cell-centre units
    return np.interp(centres, np.arange(m), eta_p)


def _scene(poses):
    bergs = []
    for k, poly in enumerate(SHAPES):
        z, theta = poses[k % len(poses)]
        berg = {"x": 4.0 + 5.0 * k, "z": z, "theta": theta}
        if poly is None:
            berg.update(width=1.0, thickness=1.4)
        else:
            berg["vertices"] = poly.tolist()
        bergs.append(berg)
    physics = {**GRID, "density_ratio": R, "wave_dt": DT}  # the wave step is one time step
    return make_scene(["gravity", "buoyancy", "waves"], bergs, physics, dt=DT)


@pytest.mark.parametrize("shift", range(len(POSES)))
def test_the_wave_kick_on_polygons_is_minus_the_gradient_of_the_clipped_areas(shift):
    """One step from rest, with a surface ``eta = 0.2 sin(0.9 x) + 0.1 cos(2.3 x)`` and
    without: the difference of the velocities times ``m / dt`` (``I / dt``) is the wave's
    force and torque, ``-rho g sum_q eta^P_q dA_q / d(x, z, theta)`` with ``A_q`` clipped in
    numpy, at poses crossing the water line, for a triangle, a pentagon, a trapezoid and a
    rectangle (the rectangles' path) in one scene."""
    poses = POSES[shift:] + POSES[:shift]
    still = Model(_scene(poses), mode="serial")
    waving = Model(_scene(poses), mode="serial")
    grid = waving.effect("waves")
    x = grid.x()
    waving.effect("waves").set_surface(0.2 * np.sin(0.9 * x) + 0.1 * np.cos(2.3 * x))
    eta_p = waving.own_rows()[: grid.cells, Wave.ETA_P].astype(np.float64)
    np.testing.assert_allclose(eta_p, 0.2 * np.sin(0.9 * x) + 0.1 * np.cos(2.3 * x), atol=1e-12)  # pressure depth 0
    eta_q = _eta_at_strips(eta_p)
    ds = grid.dx / SUB
    x0 = x[0] - 0.5 * grid.dx
    k = waving.constants()
    s0 = waving.state()
    still.advance(1)
    waving.advance(1)
    a, b = still.state(), waving.state()
    for i, poly in enumerate(SHAPES):
        corners = np.array([[0.5, -0.7], [0.5, 0.7], [-0.5, 0.7], [-0.5, -0.7]]) if poly is None else outline(poly, R)["corners"]
        pose = np.array([s0["x"][i], s0["z"][i], s0["theta"][i]])

        def potential(p, corners=corners):
            return float(eta_q @ _strip_areas(corners, p, x0, ds, len(eta_q)))

        h = 1e-6
        force = np.array([-(potential(pose + h * e) - potential(pose - h * e)) / (2 * h) for e in np.eye(3)])
        model = np.array(
            [
                (b["vx"][i] - a["vx"][i]) * k["mass"][i] / DT,
                (b["vz"][i] - a["vz"][i]) * k["mass"][i] / DT,
                (b["omega"][i] - a["omega"][i]) * k["inertia"][i] / DT,
            ]
        )
        assert np.max(np.abs(force)) > 0.01, (i, force)  # the surface pushes
        np.testing.assert_allclose(model, force, rtol=0, atol=2e-7 * np.max(np.abs(force)) + 1e-11, err_msg=str(i))


def _capsizing_pentagon(mode: str = "serial", islands=None, groups=None) -> Model:
    """A pentagon released tilted in waves, beside a trapezoid: it rolls and makes waves."""
    bergs = [
        {"x": 12.0, "z": -0.25, "theta": 0.9, "vertices": PENTAGON.tolist()},
        {"x": 14.2, "z": -0.2, "theta": -0.2, "vertices": TRAPEZOID.tolist()},
    ]
    physics = {**GRID, "density_ratio": R, "wave_sponge": 8.0, "wave_pressure_depth": 0.5}
    return Model(make_scene(["gravity", "buoyancy", "waves"], bergs, physics, dt=DT), mode=mode, islands=islands, groups=groups)


def test_polygons_in_waves_are_bit_identical_in_the_parallel_forms():
    """A pentagon released tilted beside a trapezoid in waves, serial and parallel (one group,
    and islands): the same bits (state and surface)."""
    results = []
    for mode, islands, groups in (KERNEL_FORMS[0], KERNEL_FORMS[1], KERNEL_FORMS[3]):
        m = _capsizing_pentagon(mode, islands, groups)
        m.advance(300)
        results.append((m.state(), m.effect("waves").surface()["eta"]))
    s0, eta0 = results[0]
    assert np.max(np.abs(eta0)) > 1e-4
    for s, eta in results[1:]:
        for key in s0:
            assert s[key].tobytes() == s0[key].tobytes(), key
        assert eta.tobytes() == eta0.tobytes()


def test_math_of_the_reference_clipper():
    """The reference itself: a unit square at the water line split by strips sums to its
    submerged area, and half of it lies left of its centre."""
    square = np.array([[0.5, -0.5], [0.5, 0.5], [-0.5, 0.5], [-0.5, -0.5]])
    areas = _strip_areas(square, np.array([0.0, 0.1, 0.0]), -1.0, 0.125, 16)
    assert areas.sum() == pytest.approx(0.4, abs=1e-15) and areas[:8].sum() == pytest.approx(0.2, abs=1e-15)
    assert _strip_areas(square, np.array([0.0, 0.0, math.pi / 4]), -1.0, 0.125, 16).sum() == pytest.approx(0.5, abs=1e-14)

"""Icebergs resolved by cells (``cells = [nx, nz]``, docs/bonds.md "Cells"; issue 50, item 1).

An iceberg given as nx x nz cells is nx * nz bodies that tile its outline, bonded across every
shared face. What must hold, derived rather than measured:

* the cells tile the outline, so their masses add up to its mass, their moments of inertia
  about the iceberg's centre (each ``I_c + m_c |r_c|^2``, the parallel-axis theorem) to its
  moment, and the water they displace (area and first moments of the part below the water
  line) to the water it displaces, at any pose: buoyancy's force and torque add up;
* they start moving as the rigid body (``v + omega x r``);
* with stiff, unbreakable bonds they move as the rigid block: a block of 4 x 2 cells capsizes
  when the block does (the issue's 3%). Linear drag adds up too when ``drag = angular_drag``
  (the paper's 0.01 both): each cell's ``-c m_c (v + omega x r_c)`` sums to ``-c M V`` and a
  torque ``-c omega sum m_c r_c^2``, which with the cells' own ``-c I_c omega`` is ``-c I omega``;
* the bonds join every two cells that share a face: ``nz (nx - 1) + nx (nz - 1)`` in one
  iceberg, one per layer across a shelf's joint and at the wall;
* a slab bends through its layers' stretch with the same modulus (plane strain in the
  normal and the bending spring alike): two layers of ``t / 2`` bend as one of ``t``, so a
  slab of 2 cells through its thickness rings at the 1-cell slab's flexural-gravity frequency.
"""

from __future__ import annotations

import importlib.util
import math
import subprocess
import sys

import numpy as np
import pytest

import melange_ti as mt
from melange_ti.geometry import area_centroid, below, mass_properties, rectangle
from melange_ti.io.hdf5 import read_run
from melange_ti.physics.effects.bonds import Bond
from melange_ti.physics.effects.bonds.host import build, pairs
from melange_ti.scene import DENSITY_RATIO, SceneError, loads

from ..conftest import ROOT
from .test_bonds import in_every_form, same_bits_breaking_some

R = DENSITY_RATIO
FULL = '["gravity", "buoyancy", "drag", "collisions", "wall", "bonds"]'
UNBREAKABLE = "tensile_strength = 1e9\nshear_strength = 1e9\n"
TRAPEZOID = [[-0.5, -0.7], [0.6, -0.7], [0.4, 0.7], [-0.45, 0.7]]


def scene_text(berg: str, dt=0.002, duration=1.0, physics=UNBREAKABLE, effects=FULL, snapshot=0.1, more="") -> str:
    return (
        f"[scene]\neffects = {effects}\n[physics]\n{physics}[time]\ndt = {dt}\nduration = {duration}\n"
        f"[output]\nsnapshot_interval = {snapshot}\ndiagnostic_interval = {snapshot}\n[[iceberg]]\n{berg}{more}"
    )


def whole_and_cells(berg: str, cells: str):
    """The icebergs of one scene given whole and as ``cells``."""
    whole = loads(scene_text(berg)).icebergs()
    parts = loads(scene_text(berg + f"cells = {cells}\n")).icebergs()
    return whole, parts


@pytest.mark.parametrize(
    "berg, cells",
    [
        ("x = 3.0\nz = -0.35\ntheta = 0.4\nvx = 0.1\nvz = -0.2\nomega = 0.3\n", "[4, 2]"),
        (f"x = 3.0\nz = -0.2\ntheta = -0.7\nomega = -0.5\nvertices = {TRAPEZOID}\n", "[3, 4]"),
    ],
    ids=["tilted rectangle", "trapezoid"],
)
def test_the_cells_tile_the_iceberg(berg, cells):
    """Masses, moments of inertia about the iceberg's centre and the water displaced (area
    and its first moments below the water line, at the iceberg's tilted pose) add up to the
    whole's to round-off; every cell starts with the rigid body's velocity at its centre."""
    whole, parts = whole_and_cells(berg, cells)
    nx, nz = (int(v) for v in cells.strip("[]").split(","))
    assert parts.count == nx * nz and np.all(parts.parent == 0)
    m, inertia, _ = mass_properties(whole, R)
    mc, ic, _ = mass_properties(parts, R)
    rx, rz = parts.x - whole.x[0], parts.z - whole.z[0]
    assert mc.sum() == pytest.approx(m[0], rel=1e-13)
    assert (ic + mc * (rx**2 + rz**2)).sum() == pytest.approx(inertia[0], rel=1e-12)
    np.testing.assert_allclose(parts.x @ mc / mc.sum(), whole.x[0], rtol=0, atol=1e-13)
    np.testing.assert_allclose(parts.z @ mc / mc.sum(), whole.z[0], rtol=0, atol=1e-13)
    np.testing.assert_array_equal(parts.theta, whole.theta[0])

    def wet(b):  # area and first moments of each body's part below the water line
        out = []
        for i in range(b.count):
            body = rectangle(b.width[i], b.thickness[i]) if b.outline is None else b.outline[i, : b.corners[i]]
            c, s = math.cos(b.theta[i]), math.sin(b.theta[i])
            world = np.stack([b.x[i] + body[:, 0] * c - body[:, 1] * s, b.z[i] + body[:, 0] * s + body[:, 1] * c], -1)
            a, cx, cz = area_centroid(below(world, 0.0))
            out.append((a, a * cx, a * cz))
        return np.array(out).sum(0)

    got, want = wet(parts), wet(whole)
    assert want[0] > 0.1  # partly submerged
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-13)
    om = whole.omega[0]
    np.testing.assert_allclose(parts.vx, whole.vx[0] - om * rz, rtol=0, atol=1e-15)
    np.testing.assert_allclose(parts.vz, whole.vz[0] + om * rx, rtol=0, atol=1e-15)
    np.testing.assert_array_equal(parts.omega, om)


def test_cells_are_bonded_across_every_shared_face():
    """One iceberg: every grid neighbour, each bond across the whole shared face; a bonded
    shelf (with a wall and a free front) and a shelf of leaning cuts: besides each piece's
    own, one bond per layer across each joint of the intact shelf and at the wall."""
    sc = loads(scene_text("x = 3.0\ncells = [4, 3]\n"))
    b = sc.icebergs()
    got, bad = pairs(sc, b)
    assert bad is None and len(got) == 3 * 3 + 4 * 2
    table = build(sc, b, got)
    vertical = np.isclose(table[:, Bond.LEN], 1.4 / 3, rtol=1e-12)  # faces between columns
    assert vertical.sum() == 9 and np.allclose(table[~vertical, Bond.LEN], 0.25)
    np.testing.assert_allclose(table[vertical, Bond.SPAN], 0.25)
    np.testing.assert_allclose(table[~vertical, Bond.SPAN], 1.4 / 3)
    for shelf, nx, nz in (("", 2, 3), ("cut_tilt = 0.2\n", 3, 2)):
        text = (
            f"[scene]\neffects = {FULL}\n[physics]\nbond_modulus = 10.0\n[time]\ndt = 0.001\n[shelf]\ncount = 6\n"
            f"bonded = true\nbonded_wall = true\nfront = 1\ncells = [{nx}, {nz}]\n{shelf}"
        )
        sc = loads(text)
        b = sc.icebergs()
        got, bad = pairs(sc, b)
        inner = 6 * (nz * (nx - 1) + nx * (nz - 1))
        assert bad is None and len(got) == inner + 4 * nz + nz, (len(got), inner)
        wall = [p for p in got if p[1] < 0]
        assert sorted(b.cell[[p[0] for p in wall], 1].tolist()) == list(range(nz))
        assert all(b.parent[i] == 0 and b.cell[i, 0] == 0 for i, _ in wall)
        joints = [(i, j) for i, j in got if j >= 0 and b.parent[i] != b.parent[j]]
        assert all(b.parent[j] == b.parent[i] + 1 and b.cell[i, 1] == b.cell[j, 1] for i, j in joints)
        assert max(b.parent[j] for _, j in joints) == 4  # the front piece (5) is free
        table = build(sc, b, got)
        on = table[:, Bond.A] >= 0
        area = mass_properties(b, R)[0] / R
        assert area.sum() == pytest.approx(6 * 1.4, rel=1e-12)  # the shelf tiled
        assert np.all(table[on, Bond.LEN] > 0)


def crossing(t, theta, level=math.pi / 4):
    """The time |theta| first passes ``level``, interpolated between snapshots."""
    k = int(np.argmax(np.abs(theta) > level))
    assert k > 0, "it must capsize"
    a, b = abs(theta[k - 1]), abs(theta[k])
    return t[k - 1] + (level - a) / (b - a) * (t[k] - t[k - 1])


def test_a_block_of_cells_capsizes_as_the_rigid_block(tmp_path):
    """A 1 x 1.4 block (below the critical aspect) from a tilt of 0.01, whole and as 4 x 2
    cells with unbreakable bonds of the default modulus: the cells capsize when the block
    does (the issue's 3%), turning together (their tilts within 1e-3 rad of each other)."""
    got = {}
    for cells in ("[1, 1]", "[4, 2]"):
        text = scene_text(f"x = 3.0\ntheta = 0.01\ncells = {cells}\n", dt=0.002, duration=40.0)
        mt.run(loads(text), tmp_path / "c.h5", overwrite=True)
        s = read_run(tmp_path / "c.h5")["snapshots"]
        got[cells] = (crossing(s["time"], s["theta"].mean(1)), np.ptp(s["theta"], 1).max())
    (t_block, _), (t_cells, spread) = got["[1, 1]"], got["[4, 2]"]
    assert 10 < t_block < 40
    assert t_cells == pytest.approx(t_block, rel=0.03), (t_cells, t_block)
    assert spread < 1e-3


def test_cells_run_the_same_in_every_form():
    """Two blocks of 3 x 2 cells thrown at each other (weak bonds, so some break): every
    kernel form gives the serial form's state and bonds, bit for bit."""
    text = scene_text(
        "x = 2.0\nz = -0.55\nvx = 0.6\ncells = [3, 2]\n",
        dt=0.002,
        physics="tensile_strength = 0.05\nshear_strength = 0.05\nbond_modulus = 100.0\n",
        more="[[iceberg]]\nx = 3.3\nz = -0.55\nvx = -0.6\ncells = [3, 2]\n",
    )
    same_bits_breaking_some(in_every_form(text, 300))


def test_a_run_of_cells_extends_bit_for_bit(tmp_path):
    """Run to t = 1 and extended to t = 2 is the run to t = 2 (the cells and their bonds kept)."""
    berg = "x = 3.0\ntheta = 0.3\ncells = [2, 2]\n"
    one = tmp_path / "one.h5"
    mt.run(loads(scene_text(berg, duration=2.0)), one)
    part = tmp_path / "part.h5"
    mt.run(loads(scene_text(berg, duration=1.0)), part)
    mt.extend(part, 2.0)
    a, b = read_run(one), read_run(part)
    for k in ("x", "z", "theta", "vx", "vz", "omega"):
        np.testing.assert_array_equal(a["snapshots"][k], b["snapshots"][k], err_msg=k)
    assert a["snapshots"]["x"].shape[1] == 4


_spec = importlib.util.spec_from_file_location("bonds_beam", ROOT / "validation" / "bonds_beam.py")
bb = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(bb)


def test_a_slab_of_two_layers_bends_as_one(tmp_path):
    """The first free-free flexural-gravity mode of a slab 20 w long (blocks 0.5 wide): made
    of 2 cells through its thickness, bonded layer to layer, it rings at the frequency of
    the slab of 1 (within 0.5%: a bending spring of E and a normal one of E' would part them
    by ~1%), both within 2% of the thin-plate formula."""
    one, _ = bb.mode_run(0.5, 1.0, 20.0, bb.FREE_FREE[0], periods=4.0, snapshot=0.1, work=tmp_path, layers=1)
    two, _ = bb.mode_run(0.5, 1.0, 20.0, bb.FREE_FREE[0], periods=4.0, snapshot=0.1, work=tmp_path, layers=2)
    for row in (one, two):
        assert row["omega_second_half"] == pytest.approx(row["omega_theory"], rel=0.02)
    assert two["omega_second_half"] == pytest.approx(one["omega_second_half"], rel=5e-3)


@pytest.mark.parametrize(
    "berg, key, words",
    [
        ("cells = [0, 2]\n", "iceberg[0].cells", "two integers in [1, 1000]"),
        ("cells = [2]\n", "iceberg[0].cells", "two integers in [1, 1000]"),
        ("cells = [2.5, 2]\n", "iceberg[0].cells", "two integers in [1, 1000]"),
        ('cells = "4x2"\n', "iceberg[0].cells", "two integers in [1, 1000]"),
        ("cells = [2, 2]\nvertices = [[0, 0], [1, 0], [1.2, 1], [0.5, 1.5], [-0.2, 1]]\n", "iceberg[0].cells", "4 corners"),
    ],
)
def test_bad_cells_are_refused_in_one_line(tmp_path, berg, key, words):
    path = tmp_path / "s.toml"
    path.write_text(scene_text("x = 3.0\n" + berg))
    r = subprocess.run([sys.executable, "-m", "melange_ti", "check", str(path)], capture_output=True, text=True)
    assert r.returncode == 2, r
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and key in lines[0] and words in lines[0], r.stderr


def test_cells_without_an_effect_that_joins_them_are_refused():
    with pytest.raises(SceneError, match=r"shelf.cells = \[2, 2\].*bonds effect"):
        loads('[scene]\neffects = ["gravity", "buoyancy"]\n[shelf]\ncount = 3\ncells = [2, 2]\n')


def test_cells_from_the_command_line(tmp_path):
    """``--set shelf.cells=2,3`` (as a list key's bare values) is the shelf of 2 x 3 cells."""
    sc = mt.load_scene(
        ROOT / "runs" / "shelf_breakup.toml",
        overrides={"shelf.count": 4, "shelf.cells": "2,3", "physics.bond_modulus": 10.0, "time.dt": 0.002},
    )
    assert sc.shelf.cells == [2, 3] and sc.icebergs().count == 24


def test_cells_that_meet_more_cells_than_bonds_allow_are_refused_naming_cells():
    """Pieces of different thickness (a spread) cut into 4 layers: a layer meets two of its
    neighbour's across the joint, more bonds than a body holds; refused in one line naming
    ``shelf.cells``, not the effect."""
    text = (
        f"[scene]\neffects = {FULL}\n[physics]\nbond_modulus = 10.0\n[time]\ndt = 0.002\n"
        "[shelf]\ncount = 5\nbonded = true\nbonded_wall = true\nthickness_std = 0.2\ncells = [1, 4]\n"
    )
    with pytest.raises(SceneError, match=r"^shelf.cells = \[1, 4\]: gives a cell of iceberg \d+ more than 4 bonds"):
        loads(text)

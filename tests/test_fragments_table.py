"""Fragments as bodies (``mt.fragment_table``, ``mt.capsized_area_fraction``; issue 50, item 3).

References derived, not measured: a fragment of cells that tile a rectangle ``W x T`` has the
rectangle's area, centroid and, along its principal axes, the rectangle's sides (the
equivalent rectangle ``sqrt(12 lambda / A)`` of a rectangle is itself), its long axis along
the rectangle's; a trapezoid's fragment has the trapezoid's area and second moments (Green's
sums of its corners); pieces partition the ice, so their areas add up to it at every
snapshot; and a single body's fragment is capsized exactly when the body counts as capsized
in ``capsized_fraction``.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import melange_ti as mt
from melange_ti import diagnostics
from melange_ti.geometry import polygon_moments
from melange_ti.io.hdf5 import read_run
from melange_ti.scene import DENSITY_RATIO, loads

from .physics.test_cells import TRAPEZOID, scene_text


@pytest.fixture(scope="module")
def capsizing_block(tmp_path_factory):
    """A 1 x 1.4 block of 4 x 2 cells (unbreakable bonds) capsizing from a tilt of 0.01."""
    path = tmp_path_factory.mktemp("fragments") / "block.h5"
    mt.run(loads(scene_text("x = 3.0\ntheta = 0.01\ncells = [4, 2]\n", dt=0.002, duration=40.0, snapshot=2.0)), path)
    return path


def test_a_block_of_cells_is_one_fragment_the_blocks_shape(capsizing_block):
    table = mt.fragment_table(capsizing_block)
    first = table[table["time"] == 0.0].iloc[0]
    assert (table.groupby("time").size() == 1).all() and first["bodies"] == 8
    assert first["area"] == pytest.approx(1.4, rel=1e-12)
    assert (first["length"], first["height"]) == (pytest.approx(1.4, rel=1e-9), pytest.approx(1.0, rel=1e-9))
    assert abs(first["axis_angle"]) == pytest.approx(math.pi / 2 - 0.01, abs=1e-9)  # the long axis: v, tilted 0.01
    assert first["x"] == pytest.approx(3.0, abs=1e-12)
    assert first["aspect"] == pytest.approx(1 / 1.4, rel=1e-9)
    assert first["rolls_on_end"] == (1 / 1.4 < math.sqrt(6 * DENSITY_RATIO * (1 - DENSITY_RATIO)))
    # a rigid block: its fragment's shape holds while it turns over
    np.testing.assert_allclose(table["length"], 1.4, rtol=1e-4)
    np.testing.assert_allclose(table["height"], 1.0, rtol=1e-4)


def test_the_fragment_capsizes_with_its_cells_and_counts_by_area(capsizing_block):
    """It capsizes when its cells do (they turn together), and mid-run: the area fraction is
    0 before and 1 after, as the cells' own capsized fraction."""
    table = mt.fragment_table(capsizing_block)
    snaps = read_run(capsizing_block)["snapshots"]
    cells = np.array([diagnostics.capsized_fraction(th) for th in snaps["theta"]])
    frac = mt.capsized_area_fraction(table)
    np.testing.assert_array_equal(frac.to_numpy(), cells)
    assert frac.iloc[0] == 0.0 and frac.iloc[-1] == 1.0 and 0 < np.argmax(frac.to_numpy()) < len(frac) - 1


def test_without_bonds_each_body_is_a_fragment_and_the_area_fraction_is_the_count(tmp_path):
    """The paper's row (equal blocks, no bonds), capsizing: one fragment per iceberg, and the
    capsized area fraction at each snapshot is ``capsized_fraction`` read from the diagnostics
    at that time."""
    scene = mt.load_scene(
        overrides={"shelf.count": 20, "shelf.tilt": 0.2, "shelf.gap": 0.3, "time.duration": 60.0, "output.snapshot_interval": 5.0}
    )
    mt.run(scene, tmp_path / "paper.h5")
    table = mt.fragment_table(tmp_path / "paper.h5")
    assert (table.groupby("time").size() == 20).all()
    diag = read_run(tmp_path / "paper.h5")["diagnostics"]
    frac = mt.capsized_area_fraction(table)
    want = np.interp(frac.index.to_numpy(), diag["time"], diag["capsized_fraction"])
    np.testing.assert_allclose(frac.to_numpy(), want, rtol=0, atol=1e-12)
    assert frac.iloc[-1] > 0


# two blocks of 3 x 2 cells thrown at each other with weak bonds (they break), to t = 1
BREAKING_PAIR = scene_text(
    "x = 2.0\nz = -0.55\nvx = 0.6\ncells = [3, 2]\n",
    dt=0.002,
    duration=1.0,
    physics="tensile_strength = 0.05\nshear_strength = 0.05\nbond_modulus = 100.0\n",
    more="[[iceberg]]\nx = 3.3\nz = -0.55\nvx = -0.6\ncells = [3, 2]\n",
    snapshot=0.1,
)


def test_broken_pieces_partition_the_ice(tmp_path):
    """Two blocks of 3 x 2 cells thrown at each other with weak bonds: they break into more
    pieces, whose areas and bodies add up to the ice's at every snapshot."""
    mt.run(loads(BREAKING_PAIR), tmp_path / "pair.h5")
    table = mt.fragment_table(tmp_path / "pair.h5")
    sums = table.groupby("time")[["area", "bodies"]].sum()
    np.testing.assert_allclose(sums["area"], 2 * 1.4, rtol=1e-12)
    assert (sums["bodies"] == 12).all()
    counts = table.groupby("time").size()
    assert counts.iloc[0] == 2 and counts.iloc[-1] > 2


def test_a_trapezoid_of_cells_has_the_trapezoids_moments(tmp_path):
    mt.run(loads(scene_text(f"x = 3.0\nz = -0.3\nvertices = {TRAPEZOID}\ncells = [3, 4]\n", duration=0.02)), tmp_path / "t.h5")
    row = mt.fragment_table(tmp_path / "t.h5", times=0.0).iloc[0]
    area, _, second = polygon_moments(np.array(TRAPEZOID))
    lam = np.linalg.eigvalsh(np.array([[second[0], second[2]], [second[2], second[1]]]))
    assert row["area"] == pytest.approx(area, rel=1e-12)
    assert (row["x"], row["z"]) == (pytest.approx(3.0, abs=1e-12), pytest.approx(-0.3, abs=1e-12))
    assert row["length"] == pytest.approx(math.sqrt(12 * lam[1] / area), rel=1e-10)
    assert row["height"] == pytest.approx(math.sqrt(12 * lam[0] / area), rel=1e-10)

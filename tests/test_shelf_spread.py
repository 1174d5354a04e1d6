"""A shelf of spread widths (``shelf.width_std``, issue 33): the row packs with the given gap
(none inside an intact shelf), the spread is seeded and drawn after the tilts and the
thicknesses, and the icebergs' mass and inertia follow each one's own width in a real run."""

from __future__ import annotations

import numpy as np
import pytest

from melange_ti.io.hdf5 import read_run
from melange_ti.model import Model
from melange_ti.scene import DENSITY_RATIO, loads
from melange_ti.simulation import Simulation

BASE = '[scene]\nname = "spread"\n[time]\ndt = 0.01\nduration = 0.5\nseed = 5\n[output]\nsnapshot_interval = 0.5\n'


def shelf(**keys) -> str:
    return BASE + "[shelf]\n" + "".join(f"{k} = {str(v).lower()}\n" for k, v in keys.items())


def faces(b):
    return b.x - 0.5 * b.width, b.x + 0.5 * b.width


def test_spread_widths_keep_the_gap_and_the_first_iceberg_its_place_at_the_wall():
    sc = loads(shelf(count=200, width=1.0, gap=0.15, width_std=0.2, tilt=0.0))
    b = sc.icebergs()
    left, right = faces(b)
    np.testing.assert_allclose(left[1:] - right[:-1], 0.15, rtol=0, atol=1e-12)
    assert left[0] == pytest.approx(sc.physics.wall_x + 0.15, abs=1e-15)
    assert np.std(b.width) > 0.1  # spread: a sample of 200 from N(1, 0.2)
    # the sample's mean within five standard errors of shelf.width
    assert abs(np.mean(b.width) - 1.0) < 5 * 0.2 / np.sqrt(200)


def test_the_spread_is_seeded_and_changes_nothing_drawn_before_it():
    keys = dict(count=50, tilt=0.2, thickness_std=0.1, gap=0.35)
    plain = loads(shelf(**keys)).icebergs()
    spread = loads(shelf(**keys, width_std=0.1)).icebergs()
    again = loads(shelf(**keys, width_std=0.1)).icebergs()
    other = loads(shelf(**keys, width_std=0.1).replace("seed = 5", "seed = 6")).icebergs()
    np.testing.assert_array_equal(plain.theta, spread.theta)
    np.testing.assert_array_equal(plain.thickness, spread.thickness)
    np.testing.assert_array_equal(spread.width, again.width)
    assert not np.array_equal(spread.width, other.width)
    assert np.all(plain.width == 1.0) and not np.all(spread.width == 1.0)


def test_an_intact_shelf_of_spread_widths_is_bonded_throughout_and_stays_at_rest():
    """Every neighbour touches (and is bonded), the seaward ``front`` ones keep ``gap``;
    blocks of different widths and thicknesses float at rest, so nothing moves."""
    text = shelf(count=12, bonded=True, bonded_wall=True, front=0, tilt=0.0, gap=0.3, width_std=0.15, thickness_std=0.1)
    text = text.replace(
        '[scene]\nname = "spread"\n',
        '[scene]\nname = "spread"\neffects = ["gravity", "buoyancy", "drag", "collisions", "wall", "bonds"]\n',
    )
    sc = loads(text)
    b = sc.icebergs()
    left, right = faces(b)
    np.testing.assert_allclose(left[1:] - right[:-1], 0.0, rtol=0, atol=1e-12)
    assert left[0] == sc.physics.wall_x
    m = Model(sc)
    assert int((m.own_rows()[:, 0] >= 0).sum()) == 12  # 11 neighbours and the wall
    m.advance(100)
    s = m.sample()
    assert max(np.abs(s[k]).max() for k in ("vx", "vz", "omega")) < 1e-12
    assert s["bonds_intact"] == 12 and s["fragments"] == 1

    free = loads(text.replace("front = 0", "front = 3")).icebergs()
    left, right = faces(free)
    np.testing.assert_allclose(left[1:] - right[:-1], [0.0] * 8 + [0.3] * 3, rtol=0, atol=1e-12)


def test_a_run_of_spread_widths_stores_each_width_and_its_mass(tmp_path):
    sc = loads(shelf(count=20, width_std=0.2, tilt=0.1, gap=0.25))
    Simulation(sc, tmp_path / "spread.h5", progress=False).run()
    d = read_run(tmp_path / "spread.h5")
    b = sc.icebergs()
    np.testing.assert_array_equal(d["icebergs"]["width"], b.width)
    np.testing.assert_allclose(d["icebergs"]["mass"], DENSITY_RATIO * b.width * b.thickness, rtol=1e-15)
    np.testing.assert_allclose(
        d["icebergs"]["inertia"], DENSITY_RATIO * b.width * b.thickness * (b.width**2 + b.thickness**2) / 12, rtol=1e-15
    )
    # each iceberg floats at the draft of its own thickness, whatever its width
    np.testing.assert_allclose(d["snapshots"]["z"][0], -DENSITY_RATIO * b.thickness + 0.5 * b.thickness, rtol=0, atol=1e-15)


def test_a_tilted_spread_too_tight_is_refused_with_a_gap_that_then_passes():
    """The advice reckons with each iceberg's own width, at the wall and between
    neighbours: the gap it names is accepted."""
    from melange_ti.scene import SceneError

    keys = dict(count=40, width_std=0.3, tilt=0.3, gap=0.05)
    with pytest.raises(SceneError) as err:
        loads(shelf(**keys)).icebergs()
    msg = str(err.value)
    assert msg.startswith("shelf.gap = 0.05") and "use shelf.gap >= " in msg, msg
    need = float(msg.split("use shelf.gap >= ")[1].split()[0])
    loads(shelf(**{**keys, "gap": need})).icebergs()


@pytest.mark.parametrize("cells", [[2, 2], [1, 4]])
def test_a_tilted_shelf_of_cells_too_tight_is_refused_with_a_gap_that_then_passes(cells):
    """With cells a piece tilts as a whole: the advice reckons with the piece's width and
    thickness (and its cells' smaller discs), not a cell's, and the gap it names is accepted
    (it named a cell's room, too little, before)."""
    from melange_ti.scene import SceneError

    effects = '[scene]\neffects = ["gravity", "buoyancy", "collisions", "bonds"]\n'
    head = effects + BASE.removeprefix('[scene]\nname = "spread"\n')

    def text(gap):
        return head + f"[shelf]\ncount = 40\ntilt = 0.2\ngap = {gap}\ncells = {cells}\n[physics]\nbond_modulus = 1.0\n"

    with pytest.raises(SceneError) as err:
        loads(text(0.1)).icebergs()
    msg = str(err.value)
    assert msg.startswith("shelf.gap = 0.1") and "use shelf.gap >= " in msg, msg
    need = float(msg.split("use shelf.gap >= ")[1].split()[0])
    loads(text(need)).icebergs()

"""Crevasse fields (``[shelf] crevasse_depth``, ``basal_crevasse_depth``, ``joint_strength``;
docs/bonds.md "Crevasses"; issue 50, item 2).

A joint between two bonded pieces is a crevasse open over ``d t`` from the surface and
``b t`` from the base; the bond across it holds the intact ligament between, so its face is
the band ``[bottom + b t, top - d t]``: length ``(1 - d - b) t`` (over the cosine of a
leaning cut's tilt), its point the band's middle. With cells, a layer wholly in a crevasse
is not bonded across it. ``d + b = 1`` cuts the shelf through: the paper's pre-cut shelf,
bit for bit. The model's shelf starts unstressed: every piece floats at its own draft and
the bonds are at rest in that state (docs/bonds.md derives the frontal load it leaves out),
so a shelf with no free front stays at rest.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

import melange_ti as mt
from melange_ti.geometry import body_outlines, world_outlines
from melange_ti.io.hdf5 import read_run
from melange_ti.physics.effects.bonds import Bond
from melange_ti.physics.effects.bonds.host import build, pairs
from melange_ti.scene import DENSITY_RATIO, SceneError, loads

R = DENSITY_RATIO
H = 1.4
EFFECTS = '["gravity", "buoyancy", "drag", "collisions", "wall", "bonds"]'


def shelf_scene(shelf: str, dt=0.002, duration=1.0, physics="bond_modulus = 100.0\n") -> str:
    return (
        f"[scene]\neffects = {EFFECTS}\n[physics]\n{physics}[time]\ndt = {dt}\nduration = {duration}\n"
        f"[output]\nsnapshot_interval = {duration / 4}\ndiagnostic_interval = {duration / 20}\n"
        f"[shelf]\ncount = 5\nbonded = true\nbonded_wall = true\n{shelf}"
    )


def table_of(text: str):
    sc = loads(text)
    b = sc.icebergs()
    got, bad = pairs(sc, b)
    assert bad is None
    t = build(sc, b, got)
    return sc, b, t[t[:, Bond.A] >= 0]


@pytest.mark.parametrize("tilt", [0.0, 0.25])
@pytest.mark.parametrize("d, b", [(0.0, 0.0), (0.3, 0.0), (0.0, 0.4), (0.35, 0.25)])
def test_a_joint_holds_the_ligament_between_its_crevasses(d, b, tilt):
    """Every joint's bond: length ``(1 - d - b) t / cos(tilt)``, its point at the band's
    middle height ``z0 + t (b - d) / 2`` (z0 the shelf's mid-thickness); the wall's bond
    (the grounding line) whole."""
    text = shelf_scene(f"crevasse_depth = {d}\nbasal_crevasse_depth = {b}\ncut_tilt = {tilt}\n")
    sc, bergs, t = table_of(text)
    wall = t[:, Bond.B] < 0
    joint = ~wall
    assert wall.sum() == 1 and joint.sum() == 3  # 4 bonded pieces, the front one free
    np.testing.assert_allclose(t[wall, Bond.LEN], H, rtol=1e-12)
    np.testing.assert_allclose(t[joint, Bond.LEN], (1 - d - b) * H / math.cos(tilt), rtol=1e-12)
    a = t[joint, Bond.A].astype(int)
    th = bergs.theta[a]
    height = bergs.z[a] + np.sin(th) * t[joint, Bond.UA] + np.cos(th) * t[joint, Bond.VA]
    z0 = -R * H + H / 2
    np.testing.assert_allclose(height, z0 + H * (b - d) / 2, rtol=0, atol=1e-12)


def test_with_cells_a_layer_in_a_crevasse_is_not_bonded_across_it():
    """Pieces of 2 x 4 cells, a crevasse of 0.5 from the surface and 0.25 from the base: only
    layer 1 (of 0-3 from the base) is bonded across each joint; every layer at the wall; the
    cells inside a piece all bonded, at the ice's strength while the joints hold
    ``joint_strength`` of it."""
    text = shelf_scene("crevasse_depth = 0.5\nbasal_crevasse_depth = 0.25\njoint_strength = 0.4\ncells = [2, 4]\n")
    sc, bergs, t = table_of(text)
    a, b = t[:, Bond.A].astype(int), t[:, Bond.B].astype(int)
    wall = b < 0
    joint = ~wall & (bergs.parent[a] != bergs.parent[np.maximum(b, 0)])
    assert joint.sum() == 3 and np.all(bergs.cell[a[joint], 1] == 1) and np.all(bergs.cell[b[joint], 1] == 1)
    assert wall.sum() == 4
    inner = ~wall & ~joint
    assert inner.sum() == 5 * (4 * 1 + 2 * 3)
    st = sc.physics.tensile_strength
    np.testing.assert_allclose(t[inner | wall, Bond.ST], st, rtol=1e-12)
    np.testing.assert_allclose(t[joint, Bond.ST], 0.4 * st, rtol=1e-12)
    np.testing.assert_allclose(t[joint, Bond.SS], 0.4 * sc.physics.shear_strength, rtol=1e-12)
    np.testing.assert_allclose(t[joint, Bond.LEN], H / 4, rtol=1e-12)


def test_a_shelf_cut_through_is_the_paper_scene_bit_for_bit(tmp_path):
    """``crevasse_depth = 1`` on a bonded shelf (bonds named, a Weibull spread, bonded to the
    wall): the paper's pre-cut row, free with its gaps and tilts, the same bits as the paper
    scene without bonds, through capsizes and collisions."""
    over = {"shelf.count": 30, "shelf.tilt": 0.15, "shelf.gap": 0.2, "time.duration": 40.0, "output.snapshot_interval": 2.0}
    paper = mt.load_scene(overrides=over)
    cut = mt.load_scene(
        overrides={
            **over,
            "scene.effects+": "bonds",
            "shelf.bonded": True,
            "shelf.bonded_wall": True,
            "shelf.crevasse_depth": 0.6,
            "shelf.basal_crevasse_depth": 0.4,
            "physics.strength_modulus": 5.0,
        }
    )
    mt.run(paper, tmp_path / "paper.h5")
    mt.run(cut, tmp_path / "cut.h5")
    a, b = read_run(tmp_path / "paper.h5"), read_run(tmp_path / "cut.h5")
    assert a["diagnostics"]["capsized_fraction"][-1] > 0 and a["diagnostics"]["collision_dissipated"][-1] > 0
    for k in ("x", "z", "theta", "vx", "vz", "omega"):
        np.testing.assert_array_equal(a["snapshots"][k], b["snapshots"][k], err_msg=k)
    for k, v in a["diagnostics"].items():
        np.testing.assert_array_equal(v, b["diagnostics"][k], err_msg=k)


@pytest.mark.parametrize("shelf", ["", "crevasse_depth = 0.4\n"])
def test_an_intact_shelf_with_no_free_front_starts_and_stays_unstressed(tmp_path, shelf):
    """What stress the model's shelf starts with: none. Each piece floats at its own draft and
    every face, joints included, feels the water's pressure (buoyancy is the pressure on the
    piece's whole wetted outline), so the pressures on a joint's two faces cancel and each
    piece is in equilibrium alone; the bonds form at rest in that state. A shelf with no free
    front (front = 0) so stays at rest: its bonds hold no energy beyond round-off (1e-12 of a
    piece's weight times a width) and no piece moves (1e-10 w) over 20 time units, at the
    default modulus."""
    text = shelf_scene(f"front = 0\n{shelf}", dt=0.002, duration=20.0, physics="")
    out = tmp_path / "rest.h5"
    mt.run(loads(text), out)
    d = read_run(out)
    s = d["snapshots"]
    assert d["diagnostics"]["bond_energy"].max() < 1e-12 * R * H
    for k in ("x", "z", "theta"):
        assert np.abs(s[k] - s[k][0]).max() < 1e-10, k
    assert int(d["diagnostics"]["bonds_intact"][-1]) == d["bonds"]["a"].size


def test_a_shelf_of_two_layers_settles_to_carry_its_upper_layer(tmp_path):
    """With cells through the thickness a piece's layers are not each in equilibrium: the
    upper layer (thickness ``t_c = t / 2``, top at the freeboard ``f = (1 - r) t``) weighs
    ``r w_c t_c`` and displaces ``w_c (t_c - f)``, so it presses on the lower one with
    ``F = w_c (1 - r) t_c`` (``rho_w g = 1``), which the bond between them, ``k_n = E' w_c /
    t_c``, carries in compression. The bonds start at rest, so the shelf settles to that
    state: a free shelf (no wall) of 5 pieces of 2 x 2 cells, 10 such columns, ends holding
    ``10 F^2 / (2 k_n)`` in its bonds (within 1%: the layers' sinking changes the water they
    displace by ~1e-3 of it), no bond breaks (the load is compressive), nothing moves by
    more than 1e-3 w."""
    text = shelf_scene("front = 0\ncells = [2, 2]\n", dt=0.002, duration=20.0, physics="").replace("bonded_wall = true\n", "")
    sc = loads(text)
    out = tmp_path / "layers.h5"
    mt.run(sc, out)
    d = read_run(out)
    wc, tc = 0.5, H / 2
    e_strain = sc.physics.bond_modulus / (1 - sc.physics.poisson_ratio**2)
    force, k = wc * (1 - R) * tc, e_strain * wc / tc
    want = 10 * force**2 / (2 * k)
    assert d["diagnostics"]["bond_energy"][-1] == pytest.approx(want, rel=0.01)
    assert int(d["diagnostics"]["bonds_intact"][-1]) == d["bonds"]["a"].size
    s = d["snapshots"]
    for key in ("x", "z"):
        assert np.abs(s[key] - s[key][0]).max() < 1e-3, key


@pytest.mark.parametrize(
    "shelf, key, words",
    [
        ("crevasse_depth = 1.2\n", "shelf.crevasse_depth", "[0, 1]"),
        ("crevasse_depth = -0.1\n", "shelf.crevasse_depth", "[0, 1]"),
        ("basal_crevasse_depth = 2\n", "shelf.basal_crevasse_depth", "[0, 1]"),
        ("crevasse_depth = 0.7\nbasal_crevasse_depth = 0.5\n", "shelf.basal_crevasse_depth", "add up to at most 1"),
        ("joint_strength = 0\n", "shelf.joint_strength", "> 0"),
    ],
)
def test_bad_crevasses_are_refused_naming_the_key(shelf, key, words):
    with pytest.raises(SceneError) as e:
        loads(shelf_scene(shelf))
    msg = str(e.value)
    assert key in msg and words in msg and "\n" not in msg, msg


def free_shelf(shelf: str) -> str:
    """:func:`shelf_scene` without the wall's bond."""
    return shelf_scene(shelf).replace("bonded_wall = true\n", "bonded_wall = false\n")


def bonds_as_tables(shelf: str, per_joint: dict[int, tuple[float, float]]) -> str:
    """The shelf of :func:`shelf_scene` (no wall bond) written out as ``[[iceberg]]`` tables
    (each piece where the shelf puts it, with the shelf's ``cells``) bonded by ``[[bond]]``
    tables, joint ``i`` (pieces ``i``, ``i + 1``) crevassed by ``per_joint[i] =
    (crevasse_depth, basal_crevasse_depth)``."""
    cells = re.search(r"cells = \[.*\]\n", shelf)
    whole = loads(free_shelf(re.sub(r"cells = \[.*\]\n", "", shelf)))
    b = whole.icebergs()
    out = [shelf_scene("").split("[shelf]")[0]]
    for i in range(b.count):
        out.append(
            f"[[iceberg]]\nx = {float(b.x[i])!r}\nz = {float(b.z[i])!r}\nwidth = {float(b.width[i])!r}\n"
            f"thickness = {float(b.thickness[i])!r}\ntheta = {float(b.theta[i])!r}\n{cells.group(0) if cells else ''}"
        )
    for i, (d, base) in per_joint.items():
        out.append(f"[[bond]]\na = {i}\nb = {i + 1}\ncrevasse_depth = {d!r}\nbasal_crevasse_depth = {base!r}\n")
    return "\n".join(out)


@pytest.mark.parametrize("cells", [1, 4])
def test_a_bond_tables_crevasse_is_a_shelfs_crevasse(cells):
    """``[[bond]] crevasse_depth`` and ``basal_crevasse_depth`` cut a joint as the shelf's keys
    cut every joint (the same rows, to the bit), and a joint a table leaves whole stays whole:
    each crevasse is its joint's own."""
    grid = f"cells = [1, {cells}]\n" if cells > 1 else ""
    shelf = f"crevasse_depth = 0.3\nbasal_crevasse_depth = 0.2\n{grid}"
    _, _, want = table_of(free_shelf(shelf))
    _, _, got = table_of(bonds_as_tables(shelf, {i: (0.3, 0.2) for i in range(3)}))
    np.testing.assert_array_equal(got, want)
    _, _, whole = table_of(free_shelf(grid))
    _, _, mixed = table_of(bonds_as_tables(shelf, {0: (0.3, 0.2), 1: (0.0, 0.0), 2: (0.3, 0.2)}))

    def across(t, i):  # the rows of joint i: a cell of piece i to a cell of piece i + 1, but the neighbours'
        own = [c for c in range(t.shape[1]) if c not in (Bond.NB1, Bond.NB2)]  # row numbers, which the other joints shift
        return t[(t[:, Bond.A] // cells == i) & (t[:, Bond.B] // cells == i + 1)][:, own]

    for i, like in ((0, want), (1, whole), (2, want)):
        assert across(like, i).shape[0] > 0
        np.testing.assert_array_equal(across(mixed, i), across(like, i))


@pytest.mark.parametrize(
    "bond, key, words",
    [
        ("crevasse_depth = 1.0\n", "bond[0].crevasse_depth", "[0, 1)"),
        ("basal_crevasse_depth = -0.2\n", "bond[0].basal_crevasse_depth", "[0, 1)"),
        ("crevasse_depth = 0.6\nbasal_crevasse_depth = 0.4\n", "bond[0].basal_crevasse_depth", "less than 1"),
    ],
)
def test_a_bond_tables_bad_crevasses_are_refused_naming_the_key(bond, key, words):
    text = bonds_as_tables("", {}) + f"\n[[bond]]\na = 0\nb = 1\n{bond}"
    with pytest.raises(SceneError) as e:
        loads(text)
    msg = str(e.value)
    assert key in msg and words in msg and "\n" not in msg, msg


def test_crevasses_on_a_shelf_that_is_not_bonded_are_refused():
    text = shelf_scene("crevasse_depth = 0.3\n").replace("bonded = true\n", "")
    with pytest.raises(SceneError, match=r"shelf.crevasse_depth = 0.3.*shelf.bonded = true"):
        loads(text)


def test_a_joints_bond_cut_to_its_ligament_leaves_the_walls_beside_it_touching():
    """``TOUCHING`` marks the bonds cut shorter than their pair's shared face: a crevassed
    joint's (its walls touch through contacts), not a whole joint's, a piece's inner cells',
    or the wall's; with cells, the layer cut by the crevasse's tip, not the one below it."""
    for shelf, touching in (("", set()), ("crevasse_depth = 0.3\n", {(0, 1), (1, 2), (2, 3)})):
        _, _, table = table_of(shelf_scene(shelf))
        got = {(int(r[Bond.A]), int(r[Bond.B])) for r in table if r[Bond.TOUCHING] == 1.0}
        assert got == touching, shelf
        assert set(np.unique(table[:, Bond.TOUCHING])) <= {0.0, 1.0}
    _, _, table = table_of(shelf_scene("crevasse_depth = 0.25\ncells = [1, 2]\n"))
    joint = (table[:, Bond.B] >= 0) & (np.abs(table[:, Bond.B] - table[:, Bond.A]) == 2)  # a layer to the next piece's
    upper = joint & (table[:, Bond.LEN] < 0.5)  # the upper layer's face, cut to its lower half
    assert upper.sum() == 3 and (joint & ~upper).sum() == 3
    np.testing.assert_array_equal(table[:, Bond.TOUCHING], np.where(upper, 1.0, 0.0))


def shelf_overlap(bergs, x, z, theta) -> float:
    """The deepest a corner of a piece reaches into a neighbour's outline (w; 0 if none does),
    over the shelf's neighbouring pieces (the free front, the most seaward, left out)."""
    world = world_outlines(x, z, theta, body_outlines({"width": bergs.width, "thickness": bergs.thickness}))
    order = np.argsort(bergs.x)[:-1]
    deepest = 0.0
    for a, b in zip(order[:-1], order[1:], strict=True):
        for p, q in ((world[a], world[b]), (world[b], world[a])):
            edge = np.roll(p, -1, 0) - p  # counter-clockwise: the inward normal is the edge turned left
            inward = np.stack([-edge[:, 1], edge[:, 0]], 1) / np.linalg.norm(edge, axis=1)[:, None]
            depth = np.einsum("qkd,kd->qk", q[:, None, :] - p[None, :, :], inward).min(1)
            deepest = max(deepest, float(depth.max()))
    return deepest


def soft_crevassed_shelf() -> str:
    """A soft shelf (modulus 2) of 5 pieces bonded to the wall, crevassed through 3/4 of its
    thickness, and its free front block tilted 0.2 rad, bonds unbreakable, to t = 60."""
    return (
        '[scene]\neffects = ["gravity", "buoyancy", "drag", "collisions", "wall", "bonds"]\n'
        "[physics]\nbond_modulus = 2.0\ntensile_strength = 1e3\nshear_strength = 1e3\n"
        "[time]\ndt = 0.01\nduration = 60.0\n[output]\nsnapshot_interval = 0.5\ndiagnostic_interval = 0.5\n"
        "[shelf]\ncount = 6\nbonded = true\nbonded_wall = true\nfront = 1\ntilt = 0.2\ngap = 0.1\ncrevasse_depth = 0.75\n"
    )


def test_a_crevasses_walls_touch_and_do_not_pass_through_each_other():
    """A soft shelf (modulus 2) of 5 pieces bonded to the wall, crevassed through 3/4 of its
    thickness, struck by its free front block tipping onto it (tilted 0.2 rad), its bonds
    unbreakable, to t = 60: its pieces rock at the joints. With the walls touching (contacts
    beside the ligament's bond, no overlap correction between them) no corner reaches into a
    neighbour by more than a tenth of what it does when the walls pass through (the table's
    ``TOUCHING`` set to 0 in the same model: 0.0175 w measured, against 0.0010)."""
    from melange_ti.model import Model

    sc = loads(soft_crevassed_shelf())
    bergs = sc.icebergs()
    deepest = {}
    for touching in (True, False):
        m = Model(sc)
        if not touching:
            whole = m.own_rows()
            m.own_rows("bonds", whole)[:, Bond.TOUCHING] = 0.0
            m.arrays.own.from_numpy(whole)
        deepest[touching] = 0.0
        for _ in range(120):
            m.advance(50)
            st = m.state()
            deepest[touching] = max(deepest[touching], shelf_overlap(bergs, st["x"], st["z"], st["theta"]))
        assert m.sample()["bonds_intact"] == 5  # four joints and the wall's: none broke
    assert deepest[False] > 0.01, deepest  # the case bends the joints: walls that pass through sink in
    assert deepest[True] < 0.1 * deepest[False], deepest


def test_a_shelf_with_touching_crevasse_walls_keeps_its_budget_and_every_forms_bits(tmp_path):
    """The study's crevassed shelf (``runs/shelf_breakup.toml``, N = 10, crevasses through half
    the thickness, a strength its front's capsize breaks in part): the budget within the
    promise over the run, and every kernel form the serial form's bits, bonds broken and
    intact, walls touching."""
    from pathlib import Path

    from melange_ti.energy import RESIDUAL_PROMISED, budget_series

    from .scenes import every_form

    text = (Path(__file__).resolve().parents[2] / "runs" / "shelf_breakup.toml").read_text()
    keys = [("shelf.count", 10), ("shelf.crevasse_depth", 0.5), ("shelf.tilt", 0.2), ("time.duration", 30.0)]
    keys += [("physics.tensile_strength", 0.2), ("physics.shear_strength", 0.2)]
    out = tmp_path / "crevassed.h5"
    mt.run(loads(text, keys), out, overwrite=True)
    d = read_run(out)["diagnostics"]
    assert 0 < d["bonds_intact"][-1] < d["bonds_intact"][0]
    b = budget_series(d)
    assert np.max(np.abs(b["residual"])) <= RESIDUAL_PROMISED * np.max(np.abs(b["released"]))
    every_form(loads(text, keys), 3000)


def test_a_start_from_a_crevassed_run_keeps_which_walls_touch(tmp_path):
    """A ``[start]`` from a crevassed run takes its bonds' rest geometry back from the file,
    and with it which of them leave their walls touching (``TOUCHING``, kept in
    ``/bonds/rest``): the same as the run's own table, bond for bond."""
    from melange_ti.model import Model

    src = tmp_path / "src.h5"
    mt.run(loads(shelf_scene("crevasse_depth = 0.3\n", duration=0.2)), src, overwrite=True)
    text = shelf_scene("", duration=0.2).split("[shelf]")[0] + f'[start]\nfile = "{src}"\ntime = 0.2\n'
    table = Model(loads(text)).effect("bonds").table0
    _, _, own = table_of(shelf_scene("crevasse_depth = 0.3\n"))
    assert table[:, Bond.TOUCHING].sum() == 3
    np.testing.assert_array_equal(table[: own.shape[0], Bond.TOUCHING], own[:, Bond.TOUCHING])


@pytest.mark.parametrize("version, fewer", [(8, 10), (9, 9), (10, 2)])
def test_a_checkpoint_whose_bond_table_is_an_earlier_versions_is_refused(tmp_path, version, fewer):
    """A checkpoint of an earlier melange_ti, whose bond table had fewer columns (format 8: no
    ``TOUCHING``; 9: no neighbours and crack tips, ``TIP0`` ... ``GCL`` and ``TIP``), is refused a
    resume in one line naming the table and its columns (format 10: no peak stresses,
    ``PEAK_SIG`` and ``PEAK_TAU``); the run's files are left as they were."""
    import hashlib

    from melange_ti.errors import RunError

    text = shelf_scene("crevasse_depth = 0.3\n", duration=0.2)
    out = tmp_path / "run.h5"
    mt.run(loads(text), out, overwrite=True)
    ckpt = out.with_name(out.name + ".ckpt")
    with np.load(ckpt) as z:
        ck = {k: z[k] for k in z.files}
    ck["format_version"] = np.asarray(version)
    ck["acc_bonds"] = ck["acc_bonds"][:, :-fewer]
    with open(ckpt, "wb") as fh:
        np.savez(fh, **ck)
    before = {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in tmp_path.iterdir()}
    with pytest.raises(RunError) as e:
        mt.run(loads(text.replace("duration = 0.2", "duration = 0.4")), out, resume=True)
    msg = str(e.value)
    assert "bonds" in msg and "columns" in msg and "\n" not in msg, msg
    assert {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in tmp_path.iterdir()} == before

"""Fracture energy at a crack's tip (``physics.fracture_energy``; docs/bonds.md, "Strength and
size"; issue 50, item 4): a bond at a crack's tip breaks in tension when the energy it holds
reaches ``G_c`` times its face, not by its tensile strength; every other bond by its strength.

What is derived, and asserted:

* a bond's neighbours along its face's line are the bonds whose faces continue it (a
  layer's next layer across one joint, a column's next column along one layer's face), each
  the other's; a crevassed joint's tip is the bond whose face ends at the crevasse's edge;
  with one cell per piece, the ligament's bond (its face cut: ``TOUCHING``);
* the model's own break check: a slab settled under unbreakable bonds and restarted with
  ``G_c`` a hair below the tip's energy per length breaks the tip in the first step, and the
  crack then runs to the next bond along the joint, a later step (it becomes a tip once its
  neighbour has broken); a hair above, nothing breaks. The energy is the one the study reads
  (``validation/fracture_convergence.py``);
* every kernel form gives the serial form's bits with cracks running, the budget keeps its
  promise, and a ``[start]`` keeps the tips (a bond whose neighbour broke before the start
  time is a tip);
* a bond's neighbours do not reach across a crevasse; a crevasse on a horizontal joint, and a
  fracture energy with a ``[start]`` from a file that cannot tell the tips, are refused.

With ``fracture_energy = 0`` (the default) no bit moves: the regression hashes
(``tests/regression``) hold them.
"""

from __future__ import annotations

import importlib.util

import numpy as np
import pytest

import melange_ti as mt
from melange_ti.io.hdf5 import read_run
from melange_ti.physics.effects.bonds import Bond
from melange_ti.physics.effects.bonds.host import faces_at_start
from melange_ti.scene import SceneError, loads

from ..conftest import ROOT
from .test_crevasses import table_of

_spec = importlib.util.spec_from_file_location("fracture_convergence", ROOT / "validation" / "fracture_convergence.py")
fc = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(fc)


def table(text: str):
    """The scene's icebergs and bond table at t = 0 (every row a bond: these scenes have some)."""
    _, b, t = table_of(text)
    return b, t


def test_a_bonds_neighbours_continue_its_face_and_a_crevasses_tip_is_where_its_face_ends():
    h = 0.25
    b, t = table(fc.slab_text(h, 1.0, True, dt=0.003, duration=0.01))
    point, normal, length = faces_at_start(t, b)
    for name in ("NB1", "NB2"):
        nb = t[:, getattr(Bond, name)].astype(np.int64)
        has = np.flatnonzero(nb >= 0)
        assert has.size > 0
        other = "NB2" if name == "NB1" else "NB1"
        np.testing.assert_array_equal(t[nb[has], getattr(Bond, other)], has)  # each the other's
        assert np.all(np.abs(np.abs(np.sum(normal[has] * normal[nb[has]], -1)) - 1) < 1e-12)  # parallel
        d = point[nb[has]] - point[has]
        assert np.all(np.abs(np.sum(d * normal[has], -1)) < 1e-9)  # on one line
        np.testing.assert_allclose(np.hypot(*d.T), 0.5 * (length[has] + length[nb[has]]), atol=1e-9)  # abutting
    for name, via in (("NB1", "BR1"), ("NB2", "BR2")):  # the bridge: joins their ice where the faces meet
        nb, br = (t[:, getattr(Bond, c)].astype(np.int64) for c in (name, via))
        has = np.flatnonzero(nb >= 0)
        assert np.all(br[has] >= 0) and np.all(br[nb < 0] < 0)
        ends = t[:, [Bond.A, Bond.B]].astype(np.int64)
        for r in has:
            assert set(ends[br[r]]) & set(ends[r]) and set(ends[br[r]]) & set(ends[nb[r]])
    joint = np.abs(point[:, 0] - fc.CREVASSE_X) < 1e-9
    ligament = joint & (np.abs(normal[:, 0]) > 0.5)
    assert ligament.sum() == 2  # half the thickness, cells a quarter of it
    tips = np.flatnonzero(t[:, Bond.TIP0] == 1.0)
    top_of_ligament = -fc.R + 1.0 - fc.CREVASSE_DEPTH - h / 2
    assert tips.size == 1 and ligament[tips[0]] and point[tips[0], 1] == pytest.approx(top_of_ligament)
    np.testing.assert_array_equal(t[:, Bond.TIP], t[:, Bond.TIP0])
    # one cell per piece: the crevassed joints' bonds, cut to their ligament, are the tips
    _, whole = table(fc.slab_text(1.0, 1.0, True, dt=0.003, duration=0.01))
    np.testing.assert_array_equal(whole[:, Bond.TIP0], whole[:, Bond.TOUCHING])
    assert whole[:, Bond.TIP0].sum() == 1


@pytest.fixture(scope="module")
def settled(tmp_path_factory):
    """The crevassed slab of cells a quarter of its thickness, settled under its load with
    unbreakable bonds: its file, scene text, step and the tip's energy per face length."""
    work = tmp_path_factory.mktemp("tip")
    h = 0.25
    row = fc.run(h, True, work=work)
    path = work / f"slab_{h:g}_1_7_1.h5"
    st = fc.settled(path, load_body=row["columns"])
    per = np.where(st["stress"] > 0, st["energy"] / st["length"], 0.0)
    return path, fc.slab_text(h, 1.0, True, dt=row["dt"], duration=30.0), float(per.max())


def restart(settled, factor: float, tmp_path, duration: float = 1.0):
    path, text, per = settled
    head = text.split("[[iceberg]]")[0].replace("duration = 30.0", f"duration = {duration}")
    head = head.replace("snapshot_interval = 7.5", "snapshot_interval = 0.05")
    head = head.replace("bond_damping = 0.05\n", f"bond_damping = 0.05\nfracture_energy = {factor * per!r}\n")
    out = tmp_path / f"restart_{factor}.h5"
    mt.run(loads(head + f'\n[start]\nfile = "{path}"\ntime = 30.0\n'), out, overwrite=True)
    return read_run(out)


def test_the_tip_breaks_when_its_energy_reaches_the_fracture_energy_and_the_crack_runs(settled, tmp_path):
    r = restart(settled, 0.999, tmp_path)
    bt = np.asarray(r["bonds"]["break_time"])
    first = np.flatnonzero(bt == np.nanmin(bt))
    assert first.size == 1
    tip = int(first[0])
    b, t = table(settled[1])
    assert t[tip, Bond.TIP0] == 1.0 and bt[tip] == 0.0  # the first step
    below = int(t[tip, Bond.NB1])
    assert below >= 0 and np.isfinite(bt[below]) and bt[below] > bt[tip]  # the crack ran, a step or more later
    assert np.sum(np.isfinite(bt)) == 2  # through the ligament, and no further: the rest hold by their strength
    assert np.all(np.isnan(restart(settled, 1.001, tmp_path)["bonds"]["break_time"]))


def cracking_shelf() -> str:
    """The study's shelf (``runs/shelf_breakup.toml``; with :data:`KEYS`: N = 10, 2 x 2 cells a
    piece, crevassed through half its thickness, strong bonds and a fracture energy its
    front's capsize reaches at the tips: cracks start at the crevasses and run)."""
    return (ROOT / "runs" / "shelf_breakup.toml").read_text()


KEYS = [
    ("shelf.count", 10),
    ("shelf.crevasse_depth", 0.5),
    ("shelf.cells", [2, 2]),
    ("shelf.tilt", 0.2),
    ("shelf.gap", 0.2),
    ("time.duration", 30.0),
    ("time.dt", 0.008),
    ("physics.tensile_strength", 0.5),
    ("physics.shear_strength", 0.5),
    ("physics.fracture_energy", 2e-5),
]


def test_every_form_gives_the_serial_bits_with_cracks_running_and_the_budget_holds(tmp_path):
    from melange_ti.energy import RESIDUAL_PROMISED, budget_series

    from .scenes import every_form

    text = cracking_shelf()
    out = tmp_path / "cracking.h5"
    mt.run(loads(text, KEYS), out, overwrite=True)
    d = read_run(out)["diagnostics"]
    assert 0 < d["bonds_intact"][-1] < d["bonds_intact"][0]
    b = budget_series(d)
    assert np.max(np.abs(b["residual"])) <= RESIDUAL_PROMISED * np.max(np.abs(b["released"]))
    table0 = every_form(loads(text, KEYS), 3000)
    assert np.sum(table0[:, Bond.TIP] - table0[:, Bond.TIP0]) > 0  # tips made by breaks, not only the crevasses'


def test_a_start_keeps_the_tips_and_a_broken_neighbour_makes_one(settled, tmp_path):
    """A ``[start]`` from the run whose crack went through the ligament, at a time after the
    tip broke and before the next bond did: the next bond is a tip (its neighbour is gone),
    its other neighbour renumbered with the rows kept."""
    from melange_ti.model import Model

    r = restart(settled, 0.999, tmp_path, duration=0.5)
    bt = np.asarray(r["bonds"]["break_time"])
    tip = int(np.nanargmin(bt))
    _, t = table(settled[1])
    below = int(t[tip, Bond.NB1])
    times = np.asarray(r["snapshots"]["time"])
    at = float(times[(times > bt[tip]) & (times <= bt[below])][0])  # a bond broken at t held in the state at t
    path, text, per = settled
    head = text.split("[[iceberg]]")[0].replace("bond_damping = 0.05\n", f"bond_damping = 0.05\nfracture_energy = {per!r}\n")
    src = tmp_path / "restart_0.999.h5"
    got = Model(loads(head + f'\n[start]\nfile = "{src}"\ntime = {at!r}\n')).effect("bonds").table0
    kept = np.flatnonzero(np.arange(t.shape[0]) != tip)
    renumber = {int(old): new for new, old in enumerate(kept)}
    row = renumber[below]
    assert got[row, Bond.TIP] == 1.0 and got[row, Bond.TIP0] == 0.0 and got[row, Bond.NB2] == -1.0
    assert got[row, Bond.NB1] == renumber[int(t[below, Bond.NB1])] if t[below, Bond.NB1] >= 0 else got[row, Bond.NB1] == -1.0
    rest = kept[kept != below]  # every other bond: a tip as it was from the start
    np.testing.assert_array_equal(got[[renumber[int(k)] for k in rest], Bond.TIP], t[rest, Bond.TIP0])


@pytest.mark.parametrize("value", [-1e-5])
def test_a_negative_fracture_energy_is_refused_naming_the_key(value):
    with pytest.raises(SceneError) as e:
        loads(fc.slab_text(1.0, 1.0, True, dt=0.003, duration=0.01), [("physics.fracture_energy", value)])
    msg = str(e.value)
    assert "physics.fracture_energy" in msg and ">= 0" in msg and "\n" not in msg, msg


SHELF = (
    '[scene]\neffects = ["gravity", "buoyancy", "drag", "collisions", "wall", "bonds"]\n'
    "[time]\ndt = 0.0005\nduration = 0.01\n[output]\nsnapshot_interval = 0.005\n"
    "[shelf]\ncount = 3\nbonded = true\nbonded_wall = true\ncells = [2, 4]\ncrevasse_depth = 0.6\n"
)


def test_no_neighbours_across_a_crevasse():
    """Two layers' faces that meet at a joint are neighbours only where the joint's ice is whole
    at the point they meet: below the crevasse, not in it (cells 0.35 high, the crevasse open
    over the top 0.6 of 1.4: the joint's bond in the second layer is cut to its lower 0.21)."""
    b, t = table(SHELF)
    point, normal, _ = faces_at_start(t, b)
    layer = (np.abs(normal[:, 1]) > 0.5) & (np.abs(point[:, 0] - 0.75) < 1e-9)  # piece 0's last column's layer faces
    z_top = point[:, 1].max() + 0.175  # the shelf's top
    for r in np.flatnonzero(layer):
        nbs = [int(t[r, c]) for c in (Bond.NB1, Bond.NB2) if t[r, c] >= 0]
        within = [q for q in nbs if point[q, 0] < 0.75]  # its own piece's first column
        across = [q for q in nbs if point[q, 0] > 0.75]  # the next piece's first column
        assert len(within) == 1 and point[within[0], 0] == pytest.approx(0.25)
        in_crevasse = point[r, 1] > z_top - 0.6 * 1.4
        assert (not across) == in_crevasse, (point[r], across)
        if across:
            assert point[across[0], 0] == pytest.approx(1.25) and point[across[0], 1] == pytest.approx(point[r, 1])
    assert np.flatnonzero(t[:, Bond.TIP0]).size == 1  # the cut second layer's joint bond


def test_a_crevasse_on_a_horizontal_joint_is_refused():
    text = (
        '[scene]\neffects = ["gravity", "buoyancy", "bonds"]\n[time]\ndt = 0.001\nduration = 0.01\n'
        "[[iceberg]]\nx = 0.0\nz = -0.6\nwidth = 1.0\nthickness = 0.5\n"
        "[[iceberg]]\nx = 0.0\nz = -0.1\nwidth = 1.0\nthickness = 0.5\n"
        "[[bond]]\na = 0\nb = 1\ncrevasse_depth = 0.3\n"
    )
    with pytest.raises(SceneError) as e:
        loads(text)
    msg = str(e.value)
    assert msg.startswith("bond[0].crevasse_depth = 0.3: ") and "horizontal" in msg and "\n" not in msg, msg


def test_a_start_from_a_file_that_cannot_tell_the_tips_is_refused_a_fracture_energy(tmp_path):
    """A run file written before the bonds kept their neighbours (its ``/bonds/rest`` as wide
    as format 9's), and a run ``[start]``ed from one without a fracture energy, cannot tell a
    crack's tips: a ``[start]`` from either with ``fracture_energy`` is refused in one line
    naming the key; without one it runs."""
    import h5py

    from melange_ti.physics.effects.bonds import REST

    src = tmp_path / "src.h5"
    mt.run(loads(SHELF), src, overwrite=True)
    with h5py.File(src, "r+") as f:
        rest = f["bonds/rest"][()]
        del f["bonds/rest"]
        f["bonds/rest"] = rest[:, : REST.index("TIP0")]
    head = SHELF.split("[shelf]")[0]

    def start(path, energy):
        return loads(
            head.replace("[time]", f"[physics]\nfracture_energy = {energy}\n[time]") + f'[start]\nfile = "{path}"\ntime = 0.01\n'
        )

    for path in (src, tmp_path / "again.h5"):
        with pytest.raises(SceneError) as e:
            start(path, 1e-6)
        msg = str(e.value)
        assert msg.startswith("physics.fracture_energy = ") and "[start]" in msg and "\n" not in msg, msg
        if path == src:
            mt.run(start(src, 0.0), tmp_path / "again.h5", overwrite=True)


def test_a_resumed_run_with_cracks_running_gives_the_whole_runs_bits(tmp_path):
    """The tips are state (``TIP``, in the checkpoint's bond table): the cracking shelf run to
    t = 9.424, between its breaks, and resumed to t = 12 ends where the run to t = 12 does,
    bit for bit, with bonds broken before the stop and after it."""
    keys = [k for k in KEYS if k[0] != "time.duration"]
    whole, part = tmp_path / "whole.h5", tmp_path / "part.h5"
    mt.run(loads(cracking_shelf(), keys + [("time.duration", 12.0)]), whole, overwrite=True)
    mt.run(loads(cracking_shelf(), keys + [("time.duration", 9.424)]), part, overwrite=True)
    mt.run(loads(cracking_shelf(), keys + [("time.duration", 12.0)]), part, resume=True)
    a, b = read_run(whole), read_run(part)
    bt = np.asarray(a["bonds"]["break_time"])
    assert np.sum(bt > 9.424) > 0 and np.sum(bt <= 9.424) > 0
    np.testing.assert_array_equal(bt, b["bonds"]["break_time"])
    for k in ("x", "z", "theta", "vx", "vz", "omega"):
        np.testing.assert_array_equal(a["snapshots"][k][-1], b["snapshots"][k][-1], err_msg=k)


@pytest.mark.parametrize("bridge_whole", [True, False])
def test_a_crack_does_not_jump_a_gap(bridge_whole):
    """A bond becomes a tip when its neighbour along the line breaks only while the bond that
    joins their ice where the faces meet holds (``BR1``, ``BR2``): the ligament's lower bond,
    its upper neighbour broken by hand, is a tip after one step with the column's cells still
    bonded to each other, and not with that bond broken too."""
    from melange_ti import runtime
    from melange_ti.model import Model

    runtime.init("cpu")
    text = fc.slab_text(0.25, 1.0, True, dt=0.003, duration=0.01).replace(
        "bond_damping = 0.05\n", "bond_damping = 0.05\nfracture_energy = 1.0\n"
    )
    m = Model(loads(text))
    whole = m.own_rows()
    table = m.own_rows("bonds", whole)
    tip = int(np.flatnonzero(table[:, Bond.TIP0] == 1.0)[0])
    below = int(table[tip, Bond.NB1])
    bridge = int(table[below, Bond.BR2])
    assert table[below, Bond.NB2] == tip and bridge >= 0 and table[below, Bond.TIP] == 0.0
    table[tip, Bond.INTACT] = 0.0
    if not bridge_whole:
        table[bridge, Bond.INTACT] = 0.0
    m.arrays.own.from_numpy(whole)
    m.advance(1)
    after = m.own_rows("bonds", m.own_rows())
    assert after[below, Bond.INTACT] == 1.0  # nothing broke it: G_c is far above its energy
    assert after[below, Bond.TIP] == (1.0 if bridge_whole else 0.0)

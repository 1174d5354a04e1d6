"""Bonds and waves in one scene (issue 48, point 2): effects that own a table, side by side.

Their rows are stacked in one table, the waves' grid first (its kernels index cells from row
0), the bonds after it (their kernels read their first row from the config). A bonded pair of
two 1 x 1 blocks in waves must be the 2 x 1 block: its heave period and the waves it radiates
within 1% of the single block's; and its roll too, which a free pair (no bond) does not follow.
Every form gives the serial form's bits, and the stacked table holds each owner's rows as a
scene with that owner alone builds them.
"""

from __future__ import annotations

import numpy as np
import pytest

from melange_ti.model import Model
from melange_ti.physics.data.schema import Body
from melange_ti.physics.effects.bonds import Bond
from melange_ti.physics.effects.waves import Wave
from melange_ti.scene import DENSITY_RATIO, dumps_toml, loads

from .scenes import KERNEL_FORMS
from .test_bonds import in_every_form, same_bits_breaking_some, struck_row

R = DENSITY_RATIO
WAVES = {"water_depth": 6.0, "wave_dx": 0.125, "wave_end": 200.0, "wave_sponge": 40.0}
LIFT = 0.05  # the heave's release above equilibrium
TILT = 0.05  # the roll's release
DT = 0.01
DURATION = 20.0
PROBE = 110.0  # where the radiated waves are read: 10 w seaward of the block's centre


def block_scene(pair: bool, bonded: bool = True, lift: float = LIFT, tilt: float = 0.0) -> str:
    """A 2 x 1 block at x = 100 in waves (depth 6), or the pair of 1 x 1 blocks it is cut into,
    bonded (or not) across the cut, released ``lift`` above equilibrium and tilted by ``tilt``."""
    z = -R + 0.5 + lift
    effects = ["gravity", "buoyancy", "waves"] + (["collisions", "bonds"] if pair and bonded else ["collisions"] if pair else [])
    if pair:  # the halves' centres on the tilted block's axis
        c, s = np.cos(tilt), np.sin(tilt)
        bergs = [{"x": 100.0 + d * c, "z": z + d * s, "theta": tilt, "thickness": 1.0} for d in (-0.5, 0.5)]
    else:
        bergs = [{"x": 100.0, "z": z, "theta": tilt, "width": 2.0, "thickness": 1.0}]
    doc = {
        "scene": {"name": "pair" if pair else "block", "effects": effects},
        "physics": dict(WAVES),
        "time": {"dt": DT, "duration": DURATION},
        "iceberg": bergs,
    }
    if pair and bonded:
        doc["bond"] = [{"a": 0, "b": 1}]
    return dumps_toml(doc)


def trace(text: str) -> dict[str, np.ndarray]:
    """The block's mean heave and tilt, and the surface at PROBE, every wave step (0.1)."""
    m = Model(loads(text), mode="serial")
    grid = m.effect("waves")
    probe = int(np.argmin(np.abs(grid.x() - PROBE)))
    every = grid.every
    out = {"t": [], "z": [], "theta": [], "eta": []}
    for step in range(every, round(DURATION / DT) + 1, every):
        m.advance(every)
        s = m.state()
        out["t"].append(step * DT)
        out["z"].append(float(np.mean(s["z"])) - (-R + 0.5))
        out["theta"].append(float(np.mean(s["theta"])))
        out["eta"].append(float(grid.surface()["eta"][probe]))
    return {k: np.array(v) for k, v in out.items()}


def period(t: np.ndarray, z: np.ndarray) -> float:
    """Twice the mean spacing of the oscillation's successive extrema, each placed at the vertex
    of the parabola through its sample and their neighbours (the samples are a wave step apart,
    2% of the period: a sample's own time would be only that close)."""
    i = np.flatnonzero(((z[1:-1] > z[:-2]) & (z[1:-1] >= z[2:])) | ((z[1:-1] < z[:-2]) & (z[1:-1] <= z[2:]))) + 1
    i = i[i < z.size - 1]
    assert i.size >= 4, "fewer than four extrema"
    h = t[1] - t[0]
    a, b, c = z[i - 1], z[i], z[i + 1]
    vertex = t[i] + 0.5 * h * (a - c) / (a - 2.0 * b + c)
    return float(2.0 * np.mean(np.diff(vertex)))


@pytest.fixture(scope="module")
def heave():
    return trace(block_scene(pair=False)), trace(block_scene(pair=True))


def test_a_bonded_pair_in_waves_heaves_as_the_single_block(heave):
    block, pair = heave
    period_block = period(block["t"], block["z"])
    period_pair = period(pair["t"], pair["z"])
    assert 3.0 < period_block < 8.0  # it heaved, about every 5 time units
    assert abs(period_pair - period_block) <= 0.01 * period_block
    radiated_block = np.abs(block["eta"]).max()
    radiated_pair = np.abs(pair["eta"]).max()
    assert radiated_block > 1e-3  # the block radiated waves that reached the probe
    assert abs(radiated_pair - radiated_block) <= 0.01 * radiated_block
    # and along the way, not only in the summaries
    assert np.abs(pair["z"] - block["z"]).max() <= 0.01 * np.abs(block["z"]).max()
    assert np.abs(pair["eta"] - block["eta"]).max() <= 0.01 * radiated_block


def test_a_bonded_pair_in_waves_rolls_as_the_single_block_and_a_free_pair_does_not():
    """Heave cannot tell a bond from none (both halves heave alike by symmetry); a roll can:
    the bonded halves turn as one block, free halves each on their own."""
    block = trace(block_scene(pair=False, lift=0.0, tilt=TILT))
    bonded = trace(block_scene(pair=True, lift=0.0, tilt=TILT))
    free = trace(block_scene(pair=True, bonded=False, lift=0.0, tilt=TILT))
    swing = np.abs(block["theta"]).max()
    assert swing > 0.5 * TILT
    assert np.abs(bonded["theta"] - block["theta"]).max() <= 0.01 * swing
    assert np.abs(free["theta"] - block["theta"]).max() > 0.1 * swing


def test_the_owners_rows_are_stacked_as_each_alone_builds_them():
    """Waves first (rows from 0), bonds after; each owner's rows and its slots as a scene that
    names it alone builds them (the bonds' slots moved by the grid's rows)."""
    both = Model(loads(block_scene(pair=True)), mode="serial")
    waves_only = Model(loads(block_scene(pair=True, bonded=False)), mode="serial")
    bonds_text = block_scene(pair=True).replace('"waves"', '"drag"')
    bonds_only = Model(loads(bonds_text), mode="serial")
    grid, bonds = both.effect("waves"), both.effect("bonds")
    assert grid.first_row == 0 and bonds.first_row == grid.rows
    assert both.own_rows().shape[0] == grid.rows + bonds.rows
    np.testing.assert_array_equal(both.own_rows("waves"), waves_only.own_rows())
    np.testing.assert_array_equal(both.own_rows("bonds"), bonds_only.own_rows())
    slot = both._rows()[:, Body.BOND_1]
    alone = bonds_only._rows()[:, Body.BOND_1]
    np.testing.assert_array_equal(slot, alone + grid.rows)


def struck_row_in_waves() -> str:
    """The struck bonded row of test_bonds in a short wave grid: some bonds break, others hold."""
    text = struck_row(duration=2.0)
    text = text.replace('"bonds"]', '"bonds", "waves"]')
    return text.replace("[physics]\n", "[physics]\nwater_depth = 4.0\nwave_dx = 0.25\nwave_end = 30.0\nwave_sponge = 8.0\n")


def test_bonds_and_waves_give_the_serial_forms_bits_in_every_form():
    text = struck_row_in_waves()
    forms = in_every_form(text, 400)
    m = Model(loads(text), mode="parallel", device_parts=True)  # the device's parts, on the CPU
    m.advance(400)
    forms["device_parts"] = (m.state(), m.own_rows())
    bonds = m.effect("bonds")
    same_bits_breaking_some(forms, slice(bonds.first_row, bonds.first_row + bonds.rows))
    assert np.abs(forms[KERNEL_FORMS[0]][1][: bonds.first_row, Wave.ETA]).max() > 1e-5  # and the sea moved


def test_bonds_and_waves_coloured_orders_agree_across_forms():
    text = struck_row_in_waves()
    runs = []
    for mode, kw in (("serial", {}), ("parallel", {"islands": False}), ("parallel", {"device_parts": True})):
        m = Model(loads(text), mode=mode, order="coloured", **kw)
        m.advance(400)
        runs.append((m.state(), m.own_rows()))
    for state, table in runs[1:]:
        for k in state:
            np.testing.assert_array_equal(state[k], runs[0][0][k], err_msg=k)
        np.testing.assert_array_equal(table, runs[0][1])


def test_start_from_a_run_with_bonds_and_waves_keeps_the_bonds(tmp_path):
    """``[start]`` from the struck row in waves: the bonds intact in the snapshot it starts from
    with their rest geometry, in the rows after the grid's, as from a run of bonds alone. (The
    sea starts still, as from any run with waves: the grid reads no start file, docs/model.md.)"""
    import melange_ti as mt
    from melange_ti.io.hdf5 import read_run

    text = (
        struck_row_in_waves()
        .replace("duration = 2.0", "duration = 1.5")
        .replace("snapshot_interval = 0.5", "snapshot_interval = 0.05")
    )
    mt.run(loads(text), tmp_path / "src.h5")
    src = read_run(tmp_path / "src.h5")
    t = 1.1
    bt = src["bonds"]["break_time"]
    intact = ~(bt <= t)
    assert 0 < intact.sum() < bt.size, bt
    assert np.abs(src["snapshots"]["eta"]).max() > 1e-5  # the source's sea moved
    head = text.split("[[iceberg]]")[0]
    (tmp_path / "next.toml").write_text(head + f'[start]\nfile = "src.h5"\ntime = {t}\n')
    m = Model(mt.load_scene(tmp_path / "next.toml"), mode="serial")
    bonds = m.own_rows("bonds")
    assert int((bonds[:, Bond.A] >= 0).sum()) == intact.sum()
    assert m.effect("waves").first_row == 0 and m.effect("bonds").first_row == m.effect("waves").rows
    mt.run(mt.load_scene(tmp_path / "next.toml"), tmp_path / "next.h5")
    nxt = read_run(tmp_path / "next.h5")
    np.testing.assert_array_equal(nxt["bonds"]["rest"][:, :11], src["bonds"]["rest"][intact][:, :11])  # A ... SPAN

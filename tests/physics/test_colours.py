"""Coloured contact passes (``contacts.order = "coloured"``, physics/forms/colours.py).

What is promised (docs/performance.md, "Coloured passes"): every contact coloured, no two
contacts of a colour sharing an iceberg; the same colours and the same bits in the serial
form, the parallel form on any number of threads and the device's parts (run here on the
CPU); every impulse's pair momentum exact, so a free cluster keeps its horizontal momentum
to round-off; and the energy budget closed as tightly as the sequential pass's."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import melange_ti as mt
from melange_ti.energy import total_energy
from melange_ti.model import Model
from melange_ti.physics.data.schema import ENERGY_LEDGERS, BodyInt, Contact, Counter
from melange_ti.physics.forms.colours import MAX_COLOURS, OVERFLOW
from melange_ti.scene import dumps_toml, loads

ROOT = Path(__file__).resolve().parents[2]
R = 0.8946


def jammed(order: str = "coloured", n: int = 60, effects=("gravity", "buoyancy", "drag", "collisions", "wall"), seed=5):
    """Two layers of square icebergs, the upper one resting on the lower across its gaps,
    nearly touching and driven towards the wall: contacts between neighbours, across the
    layers and with the wall from the first step (up to four partners each)."""
    rng = np.random.default_rng(seed)
    z0 = -R + 0.5
    bergs = []
    for q in range(n):
        layer = q % 2
        bergs.append(
            {
                "x": 0.51 + 0.5025 * q,
                "z": z0 + (1.002 if layer else 0.0),
                "vx": float(rng.uniform(-0.6, 0.1)),
                "vz": float(rng.uniform(-0.05, 0.05)),
                "omega": float(rng.uniform(-0.1, 0.1)),
                "width": 1.0,
                "thickness": 1.0,
            }
        )
    doc = {
        "scene": {"name": "jammed", "effects": list(effects)},
        "contacts": {"discs": 12, "order": order},
        "time": {"dt": 0.01, "duration": 1.0},
        "iceberg": bergs,
    }
    return loads(dumps_toml(doc))


def contacts_of(m: Model) -> list[tuple[int, int, int]]:
    """(i, j, colour) of every contact of the last detection (j = -1: the wall)."""
    bi, cd, cp = m.arrays.bi.to_numpy(), m.arrays.cd.to_numpy(), m.arrays.cp.to_numpy()
    slots = cp.shape[0]
    out = []
    for i in range(m.n):
        if bi[i, BodyInt.WALL_ON]:
            out.append((i, -1, int(cd[slots, i, Contact.COLOUR])))
        for s in range(bi[i, BodyInt.NCONTACT]):
            out.append((i, int(cp[s, i]), int(cd[s, i, Contact.COLOUR])))
    return out


def test_every_contact_coloured_and_no_two_of_a_colour_share_an_iceberg():
    m = Model(jammed(), mode="parallel")
    seen = 0
    worst = 0
    for _ in range(40):
        m.advance(1)
        found = contacts_of(m)
        colours = int(m.arrays.cnt.to_numpy()[Counter.COLOURS])
        seen += len(found)
        for k in range(colours):
            bodies = [b for i, j, c in found if c == k for b in (i, j) if b >= 0]
            assert len(bodies) == len(set(bodies)), f"colour {k} has two contacts on one iceberg"
        assert all(0 <= c < colours for _, _, c in found), "a contact left uncoloured"
        assert all(c != OVERFLOW for _, _, c in found)
        # a greedy colouring needs at most 2 (contacts per iceberg) - 1 colours
        degree = np.bincount([b for i, j, _ in found for b in (i, j) if b >= 0], minlength=m.n).max() if found else 0
        assert colours <= max(1, 2 * degree - 1)
        worst = max(worst, colours)
    assert seen > 40 * m.n // 2 and worst >= 3, "the scene must be jammed"
    assert m.order == "coloured" and MAX_COLOURS > worst


def _run(order="coloured", mode="parallel", device_parts=None, steps=60, n=60):
    m = Model(jammed(order, n=n), mode=mode, device_parts=device_parts)
    colours = []
    for _ in range(steps // 10):
        m.advance(10)
        colours.append(contacts_of(m) if m.order == "coloured" else None)
    return m.state(), m.totals(), colours


@pytest.fixture(scope="module")
def parallel_run():
    return _run()


@pytest.mark.parametrize("form", ["serial", "device parts"])
def test_serial_form_and_device_parts_give_the_parallel_forms_colours_and_bits(parallel_run, form):
    state, totals, colours = parallel_run
    other = _run(mode="serial") if form == "serial" else _run(device_parts=True)
    assert other[2] == colours
    for k in state:
        assert np.array_equal(other[0][k], state[k]), k
    assert other[1].impulses == totals.impulses > 100
    if form == "serial":  # the same sums in the same order
        assert other[1] == totals
    else:  # the device's block sums: within rounding of the running sum
        for name in ("collision_dissipated", "impulse_sum", "correction_work"):
            assert getattr(other[1], name) == pytest.approx(getattr(totals, name), rel=1e-12, abs=1e-15)


def test_coloured_is_another_order_than_the_sequential_pass(parallel_run):
    """The orders differ (else the test above would say nothing about colouring)."""
    state, _, _ = parallel_run
    seq, _, _ = _run(order="sequential")
    assert not np.array_equal(seq["x"], state["x"])


CHILD = """
import sys
import numpy as np
from melange_ti import runtime
runtime.init("cpu", precision="f64")
from tests.physics.test_colours import _run
state, totals, colours = _run(steps=40)
np.savez(sys.argv[1], impulses=totals.impulses, dissipated=totals.collision_dissipated, **state)
"""


def test_thread_counts_give_identical_bits(tmp_path):
    got = []
    for threads in (1, 2):
        out = tmp_path / f"t{threads}.npz"
        env = {**os.environ, "TI_CPU_MAX_NUM_THREADS": str(threads)}
        subprocess.run([sys.executable, "-c", CHILD, str(out)], check=True, cwd=ROOT, env=env, timeout=900)
        got.append(dict(np.load(out)))
    assert int(got[0]["impulses"]) > 50
    for k in got[0]:
        assert np.array_equal(got[0][k], got[1][k]), k


def test_free_cluster_keeps_its_momentum_over_ten_thousand_steps():
    """No drag, no wall: nothing but the impulses (equal and opposite, each to its pair) acts
    horizontally, and the correction moves positions only. The cluster stays packed (the
    impulses keep firing to the end)."""
    m = Model(jammed(effects=("gravity", "buoyancy", "collisions"), n=24, seed=2), mode="serial")
    mass = m.constants()["mass"]

    def momentum():
        s = m.state()
        return float(np.sum(mass * s["vx"])), float(np.sum(mass * np.abs(s["vx"])))

    p0, _ = momentum()
    counts = []
    for _ in range(10):
        before = m.totals().impulses
        m.advance(1000)
        counts.append(m.totals().impulses - before)
        p, scale = momentum()
        assert abs(p - p0) <= 1e-12 * max(scale, abs(p0)), (p, p0)
    assert min(counts) > 0, counts


def _budget(order: str):
    scene = mt.load_scene(
        overrides={"shelf.count": 40, "shelf.tilt": 0.1, "shelf.gap": 0.1, "time.dt": 0.01, "contacts.order": order}
    )
    m = Model(scene)
    s0 = m.sample()
    m.advance(15000)
    s = m.sample()
    tot = m.totals()
    ledgers = sum(float(s[name].sum()) if name in s else float(getattr(tot, name)) for name in ENERGY_LEDGERS)
    released = s0["potential"].sum() - s["potential"].sum()
    return (total_energy(s0) - total_energy(s)) - ledgers, released, tot


def test_energy_budget_closes_as_tightly_as_the_sequential_passes():
    """The packed, capsizing row of tests/physics/test_energy_budget.py in both orders: the
    coloured residual under the bound the sequential pass is held to there (5e-4 of the
    released energy)."""
    res_c, rel_c, tot_c = _budget("coloured")
    res_s, rel_s, tot_s = _budget("sequential")
    assert tot_c.impulses > 1000 and rel_c > 0.1
    assert abs(res_s) < 5e-4 * rel_s
    assert abs(res_c) < 5e-4 * rel_c, f"coloured {res_c / rel_c:.4%}, sequential {res_s / rel_s:.4%} of released"


def crowded(n_blocks: int = 40):
    """A long slab with a row of small blocks on it, each touching the slab and its
    neighbours: the slab has 40 contacts, more than the 31 colours of a mask, so some of
    its contacts take the overflow colour (solved on one thread, in body order)."""
    bw, gap = 0.5, 0.002
    length = n_blocks * (bw + gap)
    bergs = [{"x": 1.0 + length / 2, "z": -R + 0.5, "width": length, "thickness": 1.0}]
    bergs += [
        {"x": 1.0 + gap / 2 + bw / 2 + q * (bw + gap), "z": -R + 1.0 + bw / 2 + 0.001, "width": bw, "thickness": bw}
        | {"vx": 0.05 * (-1) ** q}
        for q in range(n_blocks)
    ]
    doc = {
        "scene": {"name": "crowded", "effects": ["gravity", "buoyancy", "collisions"]},
        "contacts": {"discs": 84, "order": "coloured", "max_partners": 64},
        "time": {"dt": 0.01, "duration": 1.0},
        "iceberg": bergs,
    }
    return loads(dumps_toml(doc))


def test_overflow_colour_solves_the_contacts_left_over_in_every_form():
    runs = {}
    for mode in ("serial", "parallel"):
        m = Model(crowded(), mode=mode)
        p0 = float(np.sum(m.constants()["mass"] * m.state()["vx"]))
        over = 0
        for _ in range(5):
            m.advance(5)
            found = contacts_of(m)
            over = max(over, sum(1 for _, _, c in found if c == OVERFLOW))
            for k in range(MAX_COLOURS):
                bodies = [b for i, j, c in found if c == k for b in (i, j) if b >= 0]
                assert len(bodies) == len(set(bodies))
        s = m.state()
        p = float(np.sum(m.constants()["mass"] * s["vx"]))
        assert abs(p - p0) <= 1e-13 * float(np.sum(m.constants()["mass"] * np.abs(s["vx"]))), (p, p0)
        runs[mode] = (s, m.totals(), over)
    assert runs["serial"][2] > 0, "the scene must overflow the colours"
    assert runs["serial"][1] == runs["parallel"][1] and runs["serial"][1].impulses > 100
    for k in runs["serial"][0]:
        assert np.array_equal(runs["serial"][0][k], runs["parallel"][0][k]), k

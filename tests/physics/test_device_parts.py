"""The device's parallel forms of the CPU's one-thread parts (physics/forms/device.py), run here on
the CPU: the same state bit for bit, the same islands, and the energy sums within rounding.

A device runs them by default (``Model(device_parts=True)`` off the CPU); the comparison is
with the CPU's parallel form, islands on, over a row whose neighbours collide from the first
step and which spans several blocks of bodies and cells."""

import numpy as np
import pytest

from melange_ti.model import Model
from melange_ti.physics.data.schema import BodyInt, Counter
from melange_ti.physics.forms import device
from melange_ti.scene import dumps_toml, loads

R = 0.8946
N = 600  # three blocks of bodies, four of cells


def _scene():
    h = 1.4
    rng = np.random.default_rng(5)
    gap = 0.02
    bergs = [
        {
            "x": 0.6 + q * (1 + gap),
            "z": -R * h + h / 2,
            "vx": float(rng.uniform(-0.5, 0.5)),
            "omega": float(rng.uniform(-0.2, 0.2)),
            "width": 1.0,
            "thickness": h,
        }
        for q in range(N)
    ]
    doc = {
        "scene": {"name": "device_parts", "effects": ["gravity", "buoyancy", "drag", "collisions", "wall"]},
        "contacts": {"discs": 12},
        "time": {"dt": 0.01, "duration": 1.0},
        "iceberg": bergs,
    }
    return loads(dumps_toml(doc))


def _islands(m: Model, device_parts: bool) -> tuple:
    """(count, each body's root, each root's number, each island's bodies ascending)."""
    bi = m.arrays.bi.to_numpy()
    count = int(m.arrays.cnt.to_numpy()[Counter.ISLANDS])
    roots = bi[:, BodyInt.ISLAND]
    numbers = bi[roots == np.arange(N), BodyInt.ISLAND_NUM]
    if device_parts:  # spans from the root to one past the highest body
        starts, ends = bi[:count, BodyInt.ISLAND_START], bi[:count, BodyInt.ISLAND_END]
        members = [np.flatnonzero(roots[s:e] == s) + s for s, e in zip(starts, ends, strict=True)]
    else:
        starts = bi[:count, BodyInt.ISLAND_START]
        ends = np.append(starts[1:], N)
        members = [bi[s:e, BodyInt.ISLAND_ORDER] for s, e in zip(starts, ends, strict=True)]
    return count, roots.copy(), numbers.copy(), members


def _run(device_parts: bool, steps: int):
    m = Model(_scene(), mode="parallel", islands=True, device_parts=device_parts)
    islands = []
    for _ in range(steps):
        m.advance(1)
        islands.append(_islands(m, device_parts))
    return m.state(), m.totals(), islands


@pytest.fixture(scope="module")
def both():
    return _run(False, 25), _run(True, 25)


def test_state_is_bit_identical(both):
    (s0, _, _), (s1, _, _) = both
    for k in s0:
        assert np.array_equal(s0[k], s1[k]), k


def test_islands_are_the_same(both):
    (_, _, i0), (_, _, i1) = both
    assert max(c for c, *_ in i0) > 1
    for step, (a, b) in enumerate(zip(i0, i1, strict=True)):
        assert a[0] == b[0], step
        assert np.array_equal(a[1], b[1]) and np.array_equal(a[2], b[2]), step
        assert len(a[3]) == len(b[3]) == a[0]
        for x, y in zip(a[3], b[3], strict=True):
            assert np.array_equal(x, y), step


def test_energy_sums_within_rounding_and_impulses_counted(both):
    (_, t0, _), (_, t1, _) = both
    assert t0.impulses == t1.impulses > 100
    for name in ("collision_dissipated", "impulse_offset_work", "impulse_sum", "correction_work"):
        a, b = getattr(t0, name), getattr(t1, name)
        assert abs(a - b) <= 1e-12 * max(abs(a), 1e-300), name


def test_blocks_cover_bodies_and_cells():
    assert device.red_rows(N, 1024) * device.BLOCK >= 1025
    assert device.red_rows(1, 4) >= 2

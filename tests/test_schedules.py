"""The output schedules (``IterationInterval``, as Oceananigans' ``IterationInterval``): on
their own, and as the run loop uses them (intervals rounded to whole steps, every output at
t = 0 and at the last step whether or not it falls on the schedule)."""

from __future__ import annotations

import h5py
import numpy as np

from melange_ti import scene
from melange_ti.simulation import IterationInterval, Simulation


def test_iteration_interval_fires_every_n_steps():
    every3 = IterationInterval(3)
    assert [k for k in range(13) if every3(k)] == [0, 3, 6, 9, 12]
    assert [every3.next(k) for k in range(8)] == [3, 3, 3, 6, 6, 6, 9, 9]
    every1 = IterationInterval(1)
    assert all(every1(k) for k in range(5)) and [every1.next(k) for k in range(3)] == [1, 2, 3]


def test_run_writes_on_its_schedules(tmp_path):
    dt = 0.01
    sc = scene.from_dict(
        {
            "scene": {"name": "schedules", "effects": ["gravity", "buoyancy", "drag"]},
            "time": {"dt": dt, "duration": 1.05},  # 105 steps
            # 0.254 rounds to 25 steps, 0.1 to 10; neither divides 105
            "output": {"snapshot_interval": 0.254, "diagnostic_interval": 0.1, "checkpoint_interval": 0.5},
            "shelf": {"count": 2},
        }
    )
    sim = Simulation(sc, tmp_path / "s.h5", progress=False)
    assert [o.schedule.steps for o in sim.outputs if o.schedule is not None] == [10, 25, 50]
    sim.run()
    with h5py.File(tmp_path / "s.h5", "r") as f:
        snaps = f["snapshots/time"][:]
        diags = f["diagnostics/time"][:]
    assert np.array_equal(snaps, [k * dt for k in (0, 25, 50, 75, 100, 105)])
    assert np.array_equal(diags, [k * dt for k in (*range(0, 101, 10), 105)])
    assert sim.ckpt.exists()  # a finished run keeps its last checkpoint (to be extended: tests/test_extend.py)

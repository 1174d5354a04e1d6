"""Where the energy budget's residual comes from: the paper scene (400 icebergs, t = 300)
with and without contacts, at two time steps and three restitutions.

    python validation/energy_residual_sources.py > validation/results/energy_residual_sources.txt

The residual is ``E(0) - E(t) - (drag + collisions + impulse offset + corrections)``
(stats.energy_budget), reported as a share of the potential energy released; "without
offset" leaves out ``impulse_offset_work`` (what the budget was before it was booked).
"""

import numpy as np

import melange_ti as mt
from melange_ti.analysis import stats
from melange_ti.io.hdf5 import read_run

BASE = {"time.duration": 300.0, "output.snapshot_interval": 50.0}
CASES = {
    "paper, dt 0.01": {},
    "paper, dt 0.005": {"time.dt": 0.005},
    "no collisions or wall, dt 0.01": {"scene.effects": ["gravity", "buoyancy", "drag"]},
    "no collisions or wall, dt 0.005": {"scene.effects": ["gravity", "buoyancy", "drag"], "time.dt": 0.005},
    "restitution 0, dt 0.01": {"physics.restitution": 0.0},
    "restitution 1, dt 0.01": {"physics.restitution": 1.0},
}

for k, (name, overrides) in enumerate(CASES.items()):
    path = f"residual_case{k}.h5"
    mt.run(mt.load_scene(overrides={**BASE, **overrides}), path, overwrite=True)
    b = stats.energy_budget(read_run(path)["diagnostics"])
    rel = b["released"][-1]
    without = b["residual"] + b["impulse_offset"]
    print(
        f"{name:34s} released {rel:.4f}  residual {b['residual'][-1]:+.2e} ({b['residual'][-1] / rel:+.3%}, "
        f"max {np.abs(b['residual']).max() / rel:.3%})  without offset {without[-1] / rel:+.3%}  "
        f"collisions {b['collision'][-1]:.3f}  offset {b['impulse_offset'][-1]:+.4f}  "
        f"corrections {b['correction'][-1]:+.4f}",
        flush=True,
    )

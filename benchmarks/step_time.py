"""Milliseconds per step of the paper scene (N = 400), with or without the waves effect, in the
serial form on one thread: the best of three timed advances after a warm-up. Run it with
``PYTHONPATH`` at each source tree, alternating, to compare two commits side by side:

    git worktree add /tmp/old COMMIT
    for r in 1 2 3 4 5 6; do for tree in /tmp/old .; do
        echo "$tree,paper,$(PYTHONPATH=$tree taskset -c 1 python benchmarks/step_time.py paper 30000)"
    done; done > step_time.csv
"""

import sys
import time

from melange_ti import runtime, scene

runtime.init("cpu", threads=1)
import taichi as ti  # noqa: E402

from melange_ti.model import Model  # noqa: E402

extra = [("scene.effects+", "waves")] if sys.argv[1] == "waves" else []
m = Model(scene.load(None, overrides=extra), mode="serial")
m.advance(2000)
steps = int(sys.argv[2])
best = 1e9
for _ in range(3):
    ti.sync()
    t0 = time.perf_counter()
    m.advance(steps)
    ti.sync()
    best = min(best, (time.perf_counter() - t0) / steps * 1e3)
print(f"{best:.5f}")

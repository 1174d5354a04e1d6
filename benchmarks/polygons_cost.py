"""What outlines cost a step: the paper's row of 400 blocks (1 x 1.4, gap 0.1, from x = 0.4, tilts of 0.01
rad, the paper's effects) given by width and thickness (a scene of rectangles: outlines stored
as two numbers), the same blocks given by their corners (``[[iceberg]] vertices``: every
outline's corners stored), and parallelograms of the same size whose upright faces lean 20
degrees (``--kinds``), alternating, each in a fresh process; ms per step in the serial form on
one thread, best of three timed advances of ``--steps`` after ``--warm`` steps (the blocks
capsize into each other from t ~ 50). Every outline takes the one narrow phase with candidate
lists.

    python benchmarks/polygons_cost.py --out benchmarks/results/polygons

Writes ``polygons_cost.csv`` and ``polygons_cost.png``.
"""

from __future__ import annotations

import argparse
import csv
import statistics
import subprocess
import sys
from pathlib import Path

CHILD = """
import sys, time
import numpy as np
from melange_ti import runtime
runtime.init("cpu", threads=1)
import taichi as ti
from melange_ti import scene
from melange_ti.geometry import rectangle
from melange_ti.model import Model
from melange_ti.scene.initial import equilibrium_z

kind = sys.argv[1]
lean = 0.7 * np.tan(np.radians(20.0))
shapes = {
    "polygons": {"vertices": rectangle(1.0, 1.4).tolist()},
    "parallelograms": {"vertices": [[0.5 - lean, -0.7], [0.5 + lean, 0.7], [-0.5 + lean, 0.7], [-0.5 - lean, -0.7]]},
    "rectangles": {"width": 1.0, "thickness": 1.4},
}
rng = np.random.default_rng(1)
bergs = []
for k in range(400):
    b = {"x": 0.9 + 1.1 * k, "z": float(equilibrium_z(1.4, 0.8946, 0.0)), "theta": float(rng.uniform(-0.01, 0.01))}
    b.update(shapes[kind])
    bergs.append(b)
sc = scene.from_dict({"scene": {"name": "row"}, "iceberg": bergs, "time": {"duration": 1.0}})
m = Model(sc, mode="serial")
m.advance({warm})
best = 1e9
for _ in range(3):
    ti.sync()
    t0 = time.perf_counter()
    m.advance({steps})
    ti.sync()
    best = min(best, (time.perf_counter() - t0) / {steps} * 1e3)
print(best)
"""


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", default="benchmarks/results/polygons")
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--warm", type=int, default=10000, help="steps before timing (t = 100: capsizing)")
    p.add_argument("--steps", type=int, default=2000)
    p.add_argument("--kinds", default="rectangles,polygons,parallelograms", help="rectangles, polygons (corners), parallelograms")
    a = p.parse_args()
    kinds = a.kinds.split(",")
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    for r in range(a.repeats):
        for kind in kinds:
            code = CHILD.replace("{warm}", str(a.warm)).replace("{steps}", str(a.steps))
            res = subprocess.run([sys.executable, "-c", code, kind], capture_output=True, text=True, check=True)
            ms = float(res.stdout.strip().splitlines()[-1])
            rows.append({"outline": kind, "repeat": r, "ms_per_step": ms})
            print(f"{kind} #{r}: {ms:.4f} ms/step", flush=True)
    with open(out / "polygons_cost.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    med = {k: statistics.median(q["ms_per_step"] for q in rows if q["outline"] == k) for k in kinds}
    base = med.get("rectangles", med[kinds[0]])
    print("median: " + ", ".join(f"{k} {v:.4f} ({v / base:.2f}x the time)" for k, v in med.items()))
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(5, 3.2), layout="constrained")
    for k, mark in zip(kinds, "os^v", strict=False):
        ax.plot(
            [q["repeat"] for q in rows if q["outline"] == k], [q["ms_per_step"] for q in rows if q["outline"] == k], mark, label=k
        )
    ax.set_ylim(0, None)
    ax.set_xlabel("repeat (alternating)")
    ax.set_ylabel("ms per step, serial, 1 thread")
    ax.set_title("400 blocks, capsizing: " + ", ".join(f"{k} {v / base:.2f}" for k, v in med.items()), fontsize=8)
    ax.legend(fontsize=8)
    fig.savefig(out / "polygons_cost.png", dpi=110)


if __name__ == "__main__":
    main()

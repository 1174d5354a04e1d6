"""What the waves effect costs per step: the paper scene (400 icebergs, the active state
t = 45-55) without and with waves, side by side in one process, alternating.

    python benchmarks/waves_cost.py --csv benchmarks/results/waves/waves_cost.csv

Each configuration: the shelf advanced to t = 45 in its own model, then ``--repeats`` timed
blocks of ``--steps`` steps, the configurations alternating block by block. ``wave_dx`` 0.25
(4,096 cells over 600 widths) and 0.3 (2,048 cells). Writes the CSV and a PNG beside it.
"""

from __future__ import annotations

import argparse
import csv
import time
from pathlib import Path


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--steps", type=int, default=500)
    p.add_argument("--repeats", type=int, default=5)
    p.add_argument("--csv", default="benchmarks/results/waves/waves_cost.csv")
    a = p.parse_args()
    import taichi as ti

    from melange_ti import runtime

    runtime.init("cpu", threads=1, precision="f64")
    from melange_ti.model import Model
    from melange_ti.scene import load

    paper = ["gravity", "buoyancy", "drag", "collisions", "wall"]
    configs = {
        "paper": [("scene.effects", paper)],
        "paper + waves, wave_dx 0.25": [("scene.effects", [*paper, "waves"]), ("physics.wave_dx", 0.25)],
        "paper + waves, wave_dx 0.3": [("scene.effects", [*paper, "waves"]), ("physics.wave_dx", 0.3)],
    }
    models = {}
    for name, sets in configs.items():
        m = Model(load(None, sets), mode="serial")
        m.advance(4500)
        models[name] = m
        cells = m.effect("waves").cells if m.fx.waves else 0
        print(f"{name}: {cells} wave cells", flush=True)
    times = {name: [] for name in configs}
    for _ in range(a.repeats):
        for name, m in models.items():
            ti.sync()
            t0 = time.perf_counter()
            m.advance(a.steps)
            ti.sync()
            times[name].append((time.perf_counter() - t0) / a.steps * 1e3)
    out = Path(a.csv)
    out.parent.mkdir(parents=True, exist_ok=True)
    base = min(times["paper"])
    with open(out, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["config", "wave_cells", "ms_per_step_best", "ms_per_step_median", "ratio_to_paper"])
        for name, ts in times.items():
            ts = sorted(ts)
            w.writerow(
                [
                    name,
                    models[name].effect("waves").cells if models[name].fx.waves else 0,
                    f"{ts[0]:.4f}",
                    f"{ts[len(ts) // 2]:.4f}",
                    f"{ts[0] / base:.2f}",
                ]
            )
            print(f"{name}: best {ts[0]:.3f} ms/step, median {ts[len(ts) // 2]:.3f}, {ts[0] / base:.2f}x the paper's")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 3), layout="constrained")
    names = list(times)
    ax.barh(names, [min(times[n]) for n in names], color=["0.5", "tab:blue", "tab:cyan"])
    ax.set_xlabel("ms per step (best of the alternating blocks; serial form, 1 thread)")
    ax.set_title("paper scene, 400 icebergs, t = 45-55: the cost of the waves effect", fontsize=9)
    fig.savefig(out.with_suffix(".png"), dpi=120)


if __name__ == "__main__":
    main()

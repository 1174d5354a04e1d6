"""What the bonds cost a step: the paper's shelf pre-cut (the paper scene, no bonds) against
the same icebergs as an intact bonded shelf (``bonds`` named, ``[shelf] bonded = true``,
``bonded_wall = true``, ``front = 1``), and the paper scene with ``bonds`` named but no bond
formed (the effect's presence alone), at N = 400 (serial form, one thread) and N = 100,000
(parallel form, every thread). Milliseconds per step, the best of three timed advances after
a warm-up, the three scenes alternating, each in a fresh process::

    python benchmarks/bonds_cost.py          # writes benchmarks/results/bonds/{bonds_cost.csv,.png}

The scenes differ in more than the bonds (the bonded shelf starts at rest, no gaps, and its
bonded pairs are skipped by the narrow phase; the pre-cut one capsizes), so the ratio is what
a user pays for running a shelf intact rather than pre-cut, not the bond loop alone.
"""

from __future__ import annotations

import csv
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
OUT = HERE / "results" / "bonds"
SCENES = {
    "pre-cut (paper)": [],
    "bonded shelf": [("scene.effects+", "bonds"), ("shelf.bonded", True), ("shelf.bonded_wall", True), ("shelf.front", 1)],
    "bonds named, none formed": [("scene.effects+", "bonds")],
}
SIZES = {400: (2000, 20000), 100_000: (20, 100)}  # warm-up and timed steps


def child(name: str, n: int) -> None:
    from melange_ti import runtime, scene
    from melange_ti.bench.common import time_advance

    runtime.init("cpu", threads=1 if n <= 400 else None)
    from melange_ti.model import Model

    sc = scene.load(None, overrides=[("shelf.count", n), *SCENES[name]])
    m = Model(sc)
    warm, steps = SIZES[n]
    m.advance(warm)
    print(f"{m.mode},{time_advance(m, steps, 3, pick=min) * 1e3:.5f}")


def main() -> None:
    OUT.mkdir(parents=True, exist_ok=True)
    rows = []
    for n in SIZES:
        for rep in range(3):
            for name in SCENES:
                got = (
                    subprocess.run(
                        [sys.executable, __file__, "--child", name, str(n)], check=True, capture_output=True, text=True
                    )
                    .stdout.strip()
                    .splitlines()[-1]
                )
                mode, ms = got.split(",")
                rows.append({"n": n, "scene": name, "repeat": rep, "mode": mode, "ms_per_step": float(ms)})
                print(rows[-1], flush=True)
    with open(OUT / "bonds_cost.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(SIZES), figsize=(9, 3.6))
    for ax, n in zip(axes, SIZES, strict=True):
        for k, name in enumerate(SCENES):
            v = [r["ms_per_step"] for r in rows if r["n"] == n and r["scene"] == name]
            ax.bar(k, min(v), color=("tab:gray", "tab:orange", "tab:blue")[k])
            ax.plot([k] * len(v), v, "k.", ms=4)
        ax.set_xticks(range(len(SCENES)), [s.replace(" (", "\n(").replace(", ", ",\n") for s in SCENES], fontsize=8)
        ax.set_title(f"N = {n:,}", fontsize=10)
        ax.set_ylabel("ms per step (best of 3; dots: each repeat)")
    fig.suptitle("What an intact bonded shelf costs a step (2-core CPU)", fontsize=10)
    fig.tight_layout()
    fig.savefig(OUT / "bonds_cost.png", dpi=120)


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "--child":
        child(sys.argv[2], int(sys.argv[3]))
    else:
        main()

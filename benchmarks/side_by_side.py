"""Speed of two source trees side by side, in one run (old commit vs new).

    git worktree add /tmp/old 9cd40e0
    python benchmarks/side_by_side.py --old /tmp/old --new . --out benchmarks/results/side_by_side

Each case runs in a fresh process per tree (``PYTHONPATH`` points at the tree), alternating
old and new ``--repeats`` times so that drifts of the machine hit both alike:

``paper``      the whole paper run, ``python -m melange_ti run`` (default scene), wall seconds
               of the process; ``--duration`` shortens it
``n100k``      N = 100,000 paper shelf with tilts of 0.05 rad: ``--warm`` steps, then the
               milliseconds per step of ``--steps`` more (``Model.advance``)
``waves``      the paper run with the waves effect (``scene.effects+=waves``), wall seconds
               of the process; ``--waves-duration`` (default 200) long
``lattice``    the bonded lattice shelf of ``runs/shelf_breakup.toml``: 50 pieces x [4, 2] cells,
               crevassed through half the thickness, at its bonds' step: ``--warm`` steps,
               then the milliseconds per step of ``--steps`` more (``Model.advance``)
``start``      a warm start: ``python -m melange_ti run`` of 10 icebergs for one step, wall
               seconds of the process, after one untimed run per tree fills Taichi's cache

Writes ``side_by_side.csv`` (one row per run) and ``side_by_side.png`` (median per case and
tree, new / old ratio in the title).
"""

from __future__ import annotations

import argparse
import csv
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

TIMED = """
import sys, time
from melange_ti import runtime, scene
runtime.init("cpu", precision="f64")
from melange_ti.model import Model
import taichi as ti
{scene}
m = Model(sc)
m.advance({warm})
ti.sync()
t0 = time.perf_counter()
m.advance({steps})
ti.sync()
print((time.perf_counter() - t0) / {steps} * 1e3)
"""
N100K = 'sc = scene.load(None, overrides=[("shelf.count", 100000), ("shelf.tilt", 0.05)])'
LATTICE = (
    'over = [("shelf.count", 50), ("shelf.cells", [4, 2]), ("shelf.crevasse_depth", 0.5), ("time.dt", 0.002)]\n'
    'sc = scene.load("{root}/runs/shelf_breakup.toml", overrides=over)'
)


def run_paper(tree: Path, duration: float | None, extra: tuple[str, ...] = ()) -> float:
    with tempfile.TemporaryDirectory() as d:
        cmd = [sys.executable, "-m", "melange_ti", "run", "--out", str(Path(d) / "paper.h5"), *extra]
        if duration is not None:
            cmd += ["--set", f"time.duration={duration}"]
        t0 = time.perf_counter()
        subprocess.run(cmd, check=True, env={**os.environ, "PYTHONPATH": str(tree)}, cwd=d, capture_output=True)
        return time.perf_counter() - t0


def run_n100k(tree: Path, warm: int, steps: int, template: str = N100K) -> float:
    code = TIMED.format(scene=template.format(root=Path(__file__).resolve().parents[1]), warm=warm, steps=steps)
    out = subprocess.run(
        [sys.executable, "-c", code], check=True, env={**os.environ, "PYTHONPATH": str(tree)}, capture_output=True, text=True
    )
    return float(out.stdout.strip().splitlines()[-1])


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--old", required=True, type=Path)
    p.add_argument("--new", required=True, type=Path)
    p.add_argument("--out", required=True, type=Path, help="directory for the CSV and PNG")
    p.add_argument("--repeats", type=int, default=2)
    p.add_argument("--cases", default="paper,n100k")
    p.add_argument("--duration", type=float, help="paper: time.duration (default: the scene's 8000)")
    p.add_argument("--waves-duration", type=float, default=200.0, help="waves: time.duration")
    p.add_argument("--warm", type=int, default=300)
    p.add_argument("--steps", type=int, default=100)
    a = p.parse_args()
    a.out.mkdir(parents=True, exist_ok=True)
    rows = []
    start = ("--set", "shelf.count=10")
    for case in a.cases.split(","):
        if case == "start":
            for tree in (a.old, a.new):
                run_paper(tree.resolve(), 0.01, start)
        for r in range(a.repeats):
            for label, tree in (("old", a.old), ("new", a.new)):
                if case == "paper":
                    value, unit = run_paper(tree.resolve(), a.duration), "s (whole process)"
                elif case == "waves":
                    waves = ("--set", "scene.effects+=waves")
                    value, unit = run_paper(tree.resolve(), a.waves_duration, waves), "s (whole process)"
                elif case == "start":
                    value, unit = run_paper(tree.resolve(), 0.01, start), "s (whole process)"
                elif case == "lattice":
                    value, unit = run_n100k(tree.resolve(), a.warm, a.steps, LATTICE), "ms/step"
                else:
                    value, unit = run_n100k(tree.resolve(), a.warm, a.steps), "ms/step"
                rows.append({"case": case, "tree": label, "repeat": r, "value": value, "unit": unit})
                print(f"{case} {label} #{r}: {value:.4g} {unit}", flush=True)
    with open(a.out / "side_by_side.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cases = list(dict.fromkeys(r["case"] for r in rows))
    fig, axes = plt.subplots(1, len(cases), figsize=(4.5 * len(cases), 4), squeeze=False, layout="constrained")
    for ax, case in zip(axes[0], cases, strict=True):
        med = {t: statistics.median(r["value"] for r in rows if r["case"] == case and r["tree"] == t) for t in ("old", "new")}
        for k, t in enumerate(("old", "new")):
            vals = [r["value"] for r in rows if r["case"] == case and r["tree"] == t]
            ax.scatter([k] * len(vals), vals, color="k", s=12, zorder=3)
            ax.bar(k, med[t], color=("0.7", "tab:blue")[k])
        unit = next(r["unit"] for r in rows if r["case"] == case)
        ax.set_xticks([0, 1], [f"old\n{a.old}", f"new\n{a.new}"], fontsize=8)
        ax.set_ylabel(unit)
        ax.set_title(f"{case}: new / old = {med['new'] / med['old']:.3f} (medians)", fontsize=10)
    fig.savefig(a.out / "side_by_side.png", dpi=120)
    for case in cases:
        med = {t: statistics.median(r["value"] for r in rows if r["case"] == case and r["tree"] == t) for t in ("old", "new")}
        print(f"{case}: old {med['old']:.4g}, new {med['new']:.4g}, new/old {med['new'] / med['old']:.3f}")


if __name__ == "__main__":
    main()

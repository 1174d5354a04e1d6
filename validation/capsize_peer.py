"""The paper scene's capsize curve from an independent engine (pymunk), next to melange_ti's.

    python validation/capsize_peer.py RUN.h5 [RUN.h5 ...] [--seeds 1 2] [--time 8000]
                                      [--out validation/results]

Runs the bundled paper scene (same scene file, same seeded initial state) with the pymunk
(Chipmunk2D) peer (:mod:`melange_ti.studies.peer`, which ``melange-ti bench peers`` times) --
exact polygons instead of discs, its own iterative contact solver, zero friction, restitution
via elasticities, the same numpy buoyancy and drag -- and records the capsized fraction and the leading edge every 100 time
units. melange_ti runs given as HDF5 files (e.g. ``melange-ti run --out paper.h5``) are read
for comparison. Writes ``capsize_peer.csv`` and ``capsize_peer.png``.

This is a check on the physics, not on speed: if a rigid-body engine that shares none of
melange_ti's contact code also stops far short of full capsize, the jamming seen in the
paper scene comes from the model (frictionless rectangles, restitution 0.5, linear drag)
rather than from melange_ti's contact handling. Needs ``pip install pymunk``; one pymunk
run of 8000 time units takes about 10 minutes.
"""

import argparse
import csv
from pathlib import Path

import numpy as np

from melange_ti import scene as scn
from melange_ti.diagnostics import capsized_fraction
from melange_ti.studies.peer import PymunkMelange


def pymunk_curve(seed: int, duration: float, every: float = 100.0) -> list[dict]:
    sc = scn.load(None, [("time.seed", seed)])
    ib = sc.icebergs()
    state = {k: getattr(ib, k) for k in ("x", "z", "theta", "vx", "vz", "omega", "width", "thickness")}
    peer = PymunkMelange.for_scene(state, sc)
    x0 = float(np.max(state["x"]))
    steps = round(every / sc.time.dt)
    rows = []
    for k in range(round(duration / every) + 1):
        if k:
            peer.advance(steps)
        s = peer.state()
        rows.append(
            {
                "engine": "pymunk",
                "seed": seed,
                "t": k * every,
                "capsized_fraction": capsized_fraction(s["theta"]),
                "leading_edge": float(s["x"].max()) - x0,
            }
        )
        print(f"pymunk seed {seed} t={k * every:g} capsized={rows[-1]['capsized_fraction']:.3f}", flush=True)
    return rows


def melange_curve(path: Path, every: float = 100.0) -> list[dict]:
    from melange_ti.io.hdf5 import read_run

    run = read_run(path)
    d = run["diagnostics"]
    t = np.asarray(d["time"])
    seed = int(run["attrs"]["seed"])
    rows = []
    for target in np.arange(0.0, t[-1] + 0.5 * every, every):
        i = int(np.argmin(np.abs(t - target)))
        rows.append(
            {
                "engine": "melange_ti",
                "seed": seed,
                "t": float(t[i]),
                "capsized_fraction": float(d["capsized_fraction"][i]),
                "leading_edge": float(d["leading_edge"][i]),
            }
        )
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", nargs="*", type=Path, help="melange_ti HDF5 runs of the paper scene")
    ap.add_argument("--seeds", type=int, nargs="+", default=[1])
    ap.add_argument("--time", type=float, default=8000.0)
    ap.add_argument("--out", type=Path, default=Path("validation/results"))
    a = ap.parse_args()
    rows = []
    for path in a.runs:
        rows += melange_curve(path)
    for seed in a.seeds:
        rows += pymunk_curve(seed, a.time)
    a.out.mkdir(parents=True, exist_ok=True)
    with open(a.out / "capsize_peer.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    plot(rows, a.out / "capsize_peer.png")


def plot(rows: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8))
    styles = {"melange_ti": "-", "pymunk": "--"}
    for key in sorted({(r["engine"], r["seed"]) for r in rows}):
        sel = [r for r in rows if (r["engine"], r["seed"]) == key]
        t = [r["t"] for r in sel]
        for ax, col in zip(axes, ("capsized_fraction", "leading_edge"), strict=True):
            ax.plot(t, [r[col] for r in sel], styles[key[0]], label=f"{key[0]}, seed {key[1]}")
    axes[0].axhline(0.9, color="grey", lw=0.8, ls=":")
    axes[0].set_ylabel("capsized fraction")
    axes[1].set_ylabel("leading edge (widths)")
    for ax in axes:
        ax.set_xlabel("time (sqrt(w/g))")
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.suptitle("Paper scene (400 icebergs): melange_ti against an independent engine (pymunk)")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    main()

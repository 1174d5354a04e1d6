"""Islands of touching icebergs: how big are they in the paper scene, at N = 400 and 100,000?

An island is a connected group of icebergs linked by the contacts the next step would
consider (``Model.contact_pairs``: speculative contacts included); the wall is immovable and
does not link its neighbours. Solving islands side by side pays only if no island holds
most icebergs, so this measures the largest island's share of icebergs and of contacts.

    python benchmarks/islands.py --run long/seed1.h5 --out benchmarks/results/islands
        # N = 400: snapshots of a paper run (e.g. runs/paper_long.toml) at --times
    python benchmarks/islands.py --large 100000 --out benchmarks/results/islands
        # N = 100,000 paper shelf with tilts of 0.05 rad, run to t = 50 (~3 min on 2 cores)

Writes ``islands.csv`` (appending one row per state) and prints it.
"""

from __future__ import annotations

import argparse
import csv
from pathlib import Path

import numpy as np


def islands(n: int, pairs: list[tuple[int, int]]) -> np.ndarray:
    """Island label per body (union-find; a body without contacts is its own island)."""
    parent = np.arange(n)

    def find(i: int) -> int:
        root = i
        while parent[root] != root:
            root = parent[root]
        while parent[i] != root:
            parent[i], i = root, parent[i]
        return root

    for i, j in pairs:
        ri, rj = find(i), find(j)
        if ri != rj:
            parent[max(ri, rj)] = min(ri, rj)
    return np.array([find(i) for i in range(n)])


def describe(model, label: str, t: float) -> dict:
    pairs, wall = model.contact_pairs()
    lab = islands(model.n, pairs)
    sizes = np.bincount(lab, minlength=model.n)
    big = int(np.argmax(sizes))
    in_big = sum(1 for i, _ in pairs if lab[i] == big) + sum(1 for i in wall if lab[i] == big)
    linked = sizes[sizes > 1]
    return {
        "case": label,
        "t": t,
        "n": model.n,
        "contacts": len(pairs) + len(wall),
        "islands_with_contacts": int(linked.size),
        "largest_island": int(sizes[big]),
        "largest_share_of_bodies": round(float(sizes[big]) / model.n, 4),
        "largest_share_of_contacts": round(in_big / max(1, len(pairs) + len(wall)), 4),
        "second_island": int(np.sort(sizes)[-2]) if model.n > 1 else 0,
    }


def from_run(path: Path, times: list[float]) -> list[dict]:
    from melange_ti.io.hdf5 import read_run
    from melange_ti.model import Model
    from melange_ti.scene import stored_scene

    data = read_run(path)
    sc = stored_scene(path, data)
    snaps = data["snapshots"]
    model = Model(sc)
    rows = []
    for t in times:
        k = int(np.argmin(np.abs(snaps["time"] - t)))
        model.set_state({name: snaps[name][k] for name in ("x", "z", "theta", "vx", "vz", "omega")})
        rows.append(describe(model, f"paper N={model.n} ({path.name})", float(snaps["time"][k])))
        print(rows[-1], flush=True)
    return rows


def large(n: int, times: list[float]) -> list[dict]:
    from melange_ti import scene
    from melange_ti.model import Model

    sc = scene.load(None, [("shelf.count", n), ("shelf.tilt", 0.05)])
    model = Model(sc, mode="parallel")
    dt = sc.time.dt
    rows, step = [], 0
    for t in times:
        target = int(round(t / dt))
        model.advance(target - step)
        step = target
        rows.append(describe(model, f"paper shelf N={n}, tilt 0.05", t))
        print(rows[-1], flush=True)
    return rows


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--run", type=Path, help="a paper run file: its snapshots at --times")
    p.add_argument("--times", default="100,300,1000,3000,10000,30000,60000")
    p.add_argument("--large", type=int, help="N of a paper shelf run to t = 50 (times 10..50)")
    p.add_argument("--out", type=Path, required=True)
    a = p.parse_args()
    from melange_ti import runtime

    runtime.init("cpu", precision="f64")
    rows = []
    if a.run:
        rows += from_run(a.run, [float(t) for t in a.times.split(",")])
    if a.large:
        rows += large(a.large, [10.0, 20.0, 30.0, 40.0, 50.0])
    a.out.mkdir(parents=True, exist_ok=True)
    path = a.out / "islands.csv"
    new = not path.exists()
    with open(path, "a", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        if new:
            w.writeheader()
        w.writerows(rows)
    print(f"results in {path}")


if __name__ == "__main__":
    main()

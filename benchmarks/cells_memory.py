"""A cell's memory against a whole iceberg's (issue 50, item 8): peak resident memory of a fresh
process that builds the model and steps it 20 times, for 100,000 rectangles (the paper's row)
and for 100,000 cells (a bonded shelf of 12,500 pieces x [4, 2] cells, ``runs/shelf_breakup.toml``,
its bonds included), less a process that only starts Taichi; per body.

    python benchmarks/cells_memory.py --out benchmarks/results/cells

Writes ``cells_memory.csv``.
"""

from __future__ import annotations

import argparse
import csv
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

CHILD = """
import resource, sys
from melange_ti import runtime
runtime.init("cpu", threads=1)
import melange_ti as mt
from melange_ti.model import Model
kind = sys.argv[1]
n = 0
if kind == "rectangles":
    sc = mt.load_scene(overrides={"shelf.count": 100000, "time.duration": 1.0, "shelf.tilt": 0.0})
elif kind == "cells":
    over = {"shelf.count": 12500, "shelf.cells": [4, 2], "time.duration": 1.0, "time.dt": 0.004}
    sc = mt.load_scene(ROOT + "/runs/shelf_breakup.toml", overrides=over)
if kind != "baseline":
    m = Model(sc)
    m.advance(20)
    n = sc.icebergs().count
print(n, resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024)
"""


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", default="benchmarks/results/cells")
    a = p.parse_args()
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    code = CHILD.replace("ROOT + ", repr(str(ROOT)) + " + ")
    rows = {}
    for kind in ("baseline", "rectangles", "cells"):
        res = subprocess.run([sys.executable, "-c", code, kind], capture_output=True, text=True, check=True)
        n, mib = res.stdout.strip().splitlines()[-1].split()
        rows[kind] = (int(n), float(mib))
    base = rows["baseline"][1]
    table = []
    for kind in ("rectangles", "cells"):
        n, mib = rows[kind]
        table.append(dict(scene=kind, bodies=n, peak_mib=mib, baseline_mib=base, kib_per_body=(mib - base) * 1024 / n))
        print(f"{kind}: {n} bodies, peak {mib:.1f} MiB (baseline {base:.1f}): {table[-1]['kib_per_body']:.2f} KiB per body")
    print(f"a cell / a rectangle: {table[1]['kib_per_body'] / table[0]['kib_per_body']:.2f}")
    with open(out / "cells_memory.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(table[0]))
        w.writeheader()
        w.writerows(table)


if __name__ == "__main__":
    main()

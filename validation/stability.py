"""Largest stable dt of the paper scene and of one floating block: dt raised along a ladder,
then bisected.

    python validation/stability.py [--count 400] [--time 200] [--discs 28] [--out validation/results]

The paper scene (``shelf.count`` icebergs, ``--time`` time units) is unstable at a dt where
the run would stop: it ran away (``melange_ti.energy.runaway``, the run's own rule: a
non-finite state, or the energy above its start by more than the icebergs' total mass) or its
contact slots overflowed. The block (1.4 x 1 lying flat, 1e-4 heave and roll, drag off, 60
heave periods) measures the step's linear limit ``omega dt = 2``: unstable when its
excitation energy grows 100 times (``melange_ti.studies.stability``). Writes
``stability.csv`` (every dt tried) and prints each as it finishes.
"""

import argparse
import csv
from pathlib import Path

from melange_ti import runtime
from melange_ti.studies import largest_stable_dt_paper, largest_stable_dt_single


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--count", type=int, default=400)
    p.add_argument("--time", type=float, default=200.0)
    p.add_argument("--discs", type=int, default=28)
    p.add_argument("--out", default="validation/results")
    a = p.parse_args()
    runtime.init("cpu", threads=1)

    rows = []
    name = f"paper scene N={a.count}, {a.time:g} time units, {a.discs} discs"

    def log(r: dict) -> None:
        print(f"{name}: dt={r['dt']:.4g} stable={r['stable']} ({r['reason']})", flush=True)

    paper = largest_stable_dt_paper(a.count, a.time, discs=a.discs, log=log)
    single = largest_stable_dt_single()
    for test, res in ((name, paper), ("single block heave/roll (drag off), linear limit", single)):
        for r in res["tried"]:
            bounds = {k: res.get(k, "") for k in ("largest_stable", "first_unstable", "predicted")}
            rows.append({"test": test, **r, **bounds})
        print(f"{test}: largest stable dt {res['largest_stable']:.4g}, first unstable {res['first_unstable']:.4g}", flush=True)
    print(f"linear prediction 2/omega = {single['predicted']:.4g}")
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    with open(out / "stability.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)


if __name__ == "__main__":
    main()

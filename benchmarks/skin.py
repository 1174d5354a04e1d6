"""The candidate lists' skin: the narrow phase at N = 100,000 and the paper run's step at N = 400.

    python benchmarks/skin.py --skins 0.2,1.5 --repeats 5 --out benchmarks/results/skin

A body's candidate list keeps, per partner, the disc pairs within touching distance plus a
skin (``narrow.SKIN`` times the smaller disc radius), and the narrow phase searches a pair
again only once it has moved by more than the skin allows (docs/performance.md). A wider
skin means fewer searches and more kept pairs to test; the contacts are the same bit for
bit whatever the skin. One child process per skin and case, the skins alternating
``--repeats`` times; ``narrow.SKIN`` is set before the kernels compile.

- ``large``: the paper shelf of ``--n`` icebergs (tilt 0.05) at the state in ``--state``
  (written first, by ``profile_stages.py``, if absent), the parallel form; 20 steps settled,
  ``--steps`` profiled with a sync after every kernel (``Model.profile(parts=True)``): the
  narrow phase's and the whole step's ms/step.
- ``paper``: the paper scene (400 icebergs, the serial form, one thread) advanced to
  t = 300 (mid-collapse), then ``--blocks`` blocks of 2,000 steps timed: the best block's
  µs/step.

Each child also reports its final state's largest difference from the first skin's (0: the
same bits). Writes ``skin.csv`` (every run), ``skin_summary.csv`` (medians) and ``skin.png``.
"""

from __future__ import annotations

import argparse
import csv
import json
import statistics
import sys
import time
from pathlib import Path

from children import report, run_child, saved_state, state_difference


def child(a) -> None:
    import numpy as np

    from melange_ti.physics.step import narrow

    narrow.SKIN = a.skin
    from melange_ti import runtime, scene

    runtime.init("cpu", threads=1 if a.child == "paper" else None, precision="f64")
    from melange_ti.model import Model

    if a.child == "large":
        sc = scene.load(None, overrides=[("shelf.count", a.n), ("shelf.tilt", 0.05)])
        m = Model(sc, mode="parallel", islands=False)
        m.set_state(dict(np.load(a.state)))
        m.advance(20)
        prof = m.profile(a.steps, parts=True)
        res = {"narrow_ms": prof["narrow.narrow_stage"] * 1e3, "step_ms": sum(v for k, v in prof.items() if "." not in k) * 1e3}
    else:
        m = Model(scene.load(None), mode="serial")
        m.advance(30000)  # t = 300 at dt = 0.01
        best = float("inf")
        for _ in range(a.blocks):
            t0 = time.perf_counter()
            m.advance(2000)
            best = min(best, (time.perf_counter() - t0) / 2000)
        res = {"step_us": best * 1e6}
    res["diff"] = state_difference(m.state(), a.reference)
    report(res)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--skins", default="0.2,1.5")
    p.add_argument("--cases", default="large,paper")
    p.add_argument("--repeats", type=int, default=5)
    p.add_argument("--n", type=int, default=100000)
    p.add_argument("--warm", type=int, default=4500, help="steps before the large state is saved (t = 45)")
    p.add_argument("--steps", type=int, default=20)
    p.add_argument("--blocks", type=int, default=3)
    p.add_argument("--state", default="/tmp/shelf_100k_t45.npz")
    p.add_argument("--out", default="benchmarks/results/skin")
    p.add_argument("--child", choices=("large", "paper"), help=argparse.SUPPRESS)
    p.add_argument("--skin", type=float, help=argparse.SUPPRESS)
    p.add_argument("--reference", help=argparse.SUPPRESS)
    a = p.parse_args()
    if a.child:
        child(a)
        return
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    skins = [float(s) for s in a.skins.split(",")]
    cases = a.cases.split(",")
    if "large" in cases:
        saved_state(a.state, a.n, a.warm)
    refs = {case: out / f"reference_{case}.npz" for case in cases}
    for ref in refs.values():
        ref.unlink(missing_ok=True)
    rows = []
    for r in range(a.repeats):
        for case in cases:
            for skin in skins:
                cmd = [
                    sys.executable,
                    __file__,
                    "--child",
                    case,
                    "--skin",
                    str(skin),
                    "--n",
                    str(a.n),
                    "--state",
                    a.state,
                    "--steps",
                    str(a.steps),
                    "--blocks",
                    str(a.blocks),
                    "--reference",
                    str(refs[case]),
                ]
                res = run_child(cmd)
                res.update(run=r + 1, case=case, skin=skin)
                rows.append(res)
                print(json.dumps(res), flush=True)
    for ref in refs.values():
        ref.unlink(missing_ok=True)
    worst = max(r["diff"] for r in rows)
    assert worst == 0.0, f"the skins should give the same bits, differ by {worst:.3g}"
    keys = ("narrow_ms", "step_ms", "step_us")
    with open(out / "skin.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["run", "case", "skin", *keys, "largest_state_difference"])
        for r in rows:
            w.writerow([r["run"], r["case"], r["skin"], *(f"{r[k]:.4f}" if k in r else "" for k in keys), r["diff"]])
    summary = []
    for case in cases:
        for skin in skins:
            mine = [r for r in rows if r["case"] == case and r["skin"] == skin]
            for k in keys:
                if k in mine[0]:
                    summary.append((case, skin, k, statistics.median(r[k] for r in mine), len(mine)))
    with open(out / "skin_summary.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["case", "skin", "measure", "median", "runs"])
        for row in summary:
            w.writerow([row[0], row[1], row[2], f"{row[3]:.4f}", row[4]])
    for row in summary:
        print(f"{row[0]:6s} skin {row[1]:4.2f} {row[2]:10s} median {row[3]:8.3f} ({row[4]} runs)")
    from melange_ti.bench.common import pyplot

    plt = pyplot()
    panels = [(case, k) for case in cases for k in keys if any(k in r for r in rows if r["case"] == case)]
    fig, axes = plt.subplots(1, len(panels), figsize=(4 * len(panels), 3.5), squeeze=False)
    for ax, (case, k) in zip(axes[0], panels, strict=True):
        for skin in skins:
            vals = [r[k] for r in rows if r["case"] == case and r["skin"] == skin]
            ax.plot([r for r in range(1, len(vals) + 1)], vals, "o-", label=f"skin {skin:g}")
        ax.set_xlabel("run (skins alternating)")
        unit = {"narrow_ms": "narrow phase, ms/step", "step_ms": "whole step, ms/step", "step_us": "step, µs (best block)"}[k]
        ax.set_ylabel(unit)
        ax.set_title({"large": f"N = {a.n:,}, parallel", "paper": "paper scene, N = 400, serial"}[case])
        ax.legend()
    fig.tight_layout()
    fig.savefig(out / "skin.png", dpi=110)


if __name__ == "__main__":
    main()

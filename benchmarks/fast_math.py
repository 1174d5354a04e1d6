"""What vector code would buy at large N: each kernel with Taichi's ``fast_math`` off and on.

    python benchmarks/fast_math.py --state /tmp/shelf_100k_t45.npz --out benchmarks/results/fast_math

Taichi 1.7 emits scalar code on the CPU; its ``fast_math`` flag lets LLVM reassociate
floating point (and so vectorise some loops and fold some divisions), which changes results
in the last bits: melange_ti always runs with it off (``runtime.init``). This script measures
the lever anyway, to know what a vectorising backend that keeps the bits could gain at most.

The paper shelf of ``--n`` icebergs (tilt 0.05) is advanced ``--warm`` steps once in the
parallel form and its state saved to ``--state`` (reused if present). Then child processes,
``fast_math`` off and on alternating ``--repeats`` times, each read the state, take
``--settle`` steps, profile ``--steps`` steps with a sync after every kernel
(``Model.profile(parts=True)``), and step ``--compare`` more steps unprofiled: the children
print their per-kernel times and their final state's largest difference (any variable of
``Model.state()``) from the state the first ``off`` child reached (0 for every ``off`` child: the runs are bit-identical).
Writes ``fast_math.csv`` (median ms/step per kernel and mode, and the ratio),
``fast_math_runs.csv`` (every run's ms/step per kernel) and ``fast_math.png``.
"""

from __future__ import annotations

import argparse
import csv
import statistics
import sys
from pathlib import Path

from children import report, run_child, saved_state, state_difference


def child(a) -> None:
    import numpy as np
    import taichi as ti

    if a.child == "on":
        original = ti.init

        def init(*args, **kwargs):
            kwargs["fast_math"] = True
            return original(*args, **kwargs)

        ti.init = init  # runtime.init passes fast_math=False; this run overrides it
    from melange_ti import runtime, scene

    runtime.init("cpu", precision="f64")
    assert ti.lang.impl.current_cfg().fast_math == (a.child == "on")
    from melange_ti.model import Model

    sc = scene.load(None, overrides=[("shelf.count", a.n), ("shelf.tilt", 0.05)])
    m = Model(sc, mode="parallel", islands=False)
    m.set_state(dict(np.load(a.state)))
    m.advance(a.settle)
    prof = m.profile(a.steps, parts=True)
    m.advance(a.compare)
    diff = state_difference(m.state(), Path(a.state).with_suffix(".reference.npz"))  # the first child is an 'off' one
    threads = ti.lang.impl.current_cfg().cpu_max_num_threads
    report({"mode": a.child, "profile": prof, "diff": diff, "threads": threads})


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--n", type=int, default=100000)
    p.add_argument("--warm", type=int, default=4500, help="steps before the state is saved (t = 45 at dt 0.01)")
    p.add_argument("--settle", type=int, default=20)
    p.add_argument("--steps", type=int, default=20)
    p.add_argument("--compare", type=int, default=20)
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--state", default="/tmp/shelf_100k_t45.npz")
    p.add_argument("--out", default="benchmarks/results/fast_math")
    p.add_argument("--child", choices=("off", "on"), help=argparse.SUPPRESS)
    a = p.parse_args()
    if a.child:
        child(a)
        return
    saved_state(a.state, a.n, a.warm)
    Path(a.state).with_suffix(".reference.npz").unlink(missing_ok=True)
    runs = []
    for r in range(a.repeats):
        for mode in ("off", "on"):
            cmd = [
                sys.executable,
                __file__,
                "--child",
                mode,
                "--n",
                str(a.n),
                "--state",
                a.state,
                "--settle",
                str(a.settle),
                "--steps",
                str(a.steps),
                "--compare",
                str(a.compare),
            ]
            res = run_child(cmd)
            total = sum(v for k, v in res["profile"].items() if "." not in k)
            after = a.settle + a.steps + a.compare
            print(
                f"run {r + 1}, fast_math {mode}: {total * 1e3:.2f} ms/step; largest difference of the state "
                f"from the first 'off' run after {after} steps: {res['diff']:.3g}",
                flush=True,
            )
            runs.append(res)
    off_diff = max(r["diff"] for r in runs if r["mode"] == "off")
    assert off_diff == 0.0, f"the fast_math-off runs should be bit-identical, differ by {off_diff:.3g}"
    kernels = [k for k in runs[0]["profile"] if "." in k]
    rows = []
    for k in [*kernels, "step"]:
        med = {}
        for mode in ("off", "on"):
            vals = [
                (sum(v for kk, v in r["profile"].items() if "." not in kk) if k == "step" else r["profile"][k]) * 1e3
                for r in runs
                if r["mode"] == mode
            ]
            med[mode] = statistics.median(vals)
        rows.append((k, med["off"], med["on"], med["on"] / med["off"] if med["off"] > 0 else float("nan")))
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    with open(out / "fast_math.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["kernel", "ms_per_step_off", "ms_per_step_on", "on_over_off", "n", "repeats", "largest_state_difference_on"])
        worst = max(r["diff"] for r in runs if r["mode"] == "on")
        for k, off, on, ratio in rows:
            w.writerow([k, f"{off:.4f}", f"{on:.4f}", f"{ratio:.3f}", a.n, a.repeats, f"{worst:.3g}"])
    with open(out / "fast_math_runs.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["run", "mode", "kernel", "ms_per_step", "largest_state_difference"])
        for q, r in enumerate(runs):
            step = sum(v for k, v in r["profile"].items() if "." not in k)
            for k in [*kernels, "step"]:
                v = step if k == "step" else r["profile"][k]
                w.writerow([q // 2 + 1, r["mode"], k, f"{v * 1e3:.4f}", f"{r['diff']:.3g}"])
    print(f"{'kernel':40s} {'off':>8s} {'on':>8s} {'on/off':>7s}")
    for k, off, on, ratio in rows:
        print(f"{k:40s} {off:8.3f} {on:8.3f} {ratio:7.3f}")
    from melange_ti.bench.common import pyplot

    plt = pyplot()
    shown = [r for r in rows if r[0] != "step" and max(r[1], r[2]) > 0.2]
    fig, ax = plt.subplots(figsize=(8, 0.35 * len(shown) + 1.5))
    ys = range(len(shown))
    ax.barh([y + 0.2 for y in ys], [r[1] for r in shown], height=0.4, label="fast_math off (what runs)")
    ax.barh([y - 0.2 for y in ys], [r[2] for r in shown], height=0.4, label="fast_math on (not bit-identical)")
    ax.set_yticks(list(ys), [r[0] for r in shown])
    ax.invert_yaxis()
    step = rows[-1]
    ax.set_xlabel(f"ms per step (median of {a.repeats}, alternating)")
    threads = runs[0]["threads"]
    ax.set_title(f"N = {a.n:,}, parallel form, {threads} threads: step {step[1]:.2f} -> {step[2]:.2f} ms ({step[3]:.2f}x)")
    ax.legend()
    fig.tight_layout()
    fig.savefig(out / "fast_math.png", dpi=120)


if __name__ == "__main__":
    main()

"""Are the step's per-body passes bound by memory? Each kernel's time per body where the rows
sit in the cache and where they do not, next to passes at memory speed over the same rows.

    python benchmarks/row_passes.py --out benchmarks/results/row_passes

For each N in ``--sizes``: the paper shelf (tilt 0.05) advanced ``--warm`` steps in the
parallel form (islands off, groups one per thread), ``--settle`` more, then
``Model.profile(--steps, parts=True)`` ``--repeats`` times, the sizes alternating; the median
per kernel, as nanoseconds per body. Then, on each model's own body array (N rows of the
schema's columns, f64), two passes at memory speed, timed the same way: ``one line`` reads one
column a row (one 64-byte cache line a body), ``whole row`` adds to one column on every cache
line of the row (every byte of the row read and written: the most memory traffic a pass over
the bodies' rows can make). A kernel many times slower per body than ``whole row``, at the
size where the rows come from memory as where they sit in the cache, is bound by its
arithmetic: fusing it with another pass can save at most that other pass's memory traffic.
Writes ``row_passes.csv`` and ``row_passes.png``.
"""

import argparse
import csv
import statistics
import time
from pathlib import Path


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--sizes", default="40000,200000")
    p.add_argument("--warm", type=int, default=1000)
    p.add_argument("--settle", type=int, default=20)
    p.add_argument("--steps", type=int, default=40)
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--out", default="benchmarks/results/row_passes")
    a = p.parse_args()
    import taichi as ti

    from melange_ti import runtime, scene
    from melange_ti.bench.common import pyplot

    runtime.init("cpu", precision="f64")
    from melange_ti.model import Model
    from melange_ti.physics.data.schema import LINE_COLUMNS

    @ti.kernel
    def one_line(b: ti.types.ndarray()) -> ti.f64:
        s = 0.0
        for i in range(b.shape[0]):
            s += b[i, 0]
        return s

    @ti.kernel
    def whole_row(b: ti.types.ndarray(), lines: ti.template()):
        for i in range(b.shape[0]):
            for k in ti.static(range(lines)):
                b[i, k * LINE_COLUMNS] += 0.5

    sizes = [int(s) for s in a.sizes.split(",")]
    models = {}
    for n in sizes:
        m = Model(scene.load(None, overrides=[("shelf.count", n), ("shelf.tilt", 0.05)]), mode="parallel", islands=False)
        m.advance(a.warm + a.settle)
        models[n] = m
        print(f"N = {n}: {m.arrays.b.shape[1]} columns a row", flush=True)
    times = {n: {} for n in sizes}
    for _ in range(a.repeats):
        for n, m in models.items():
            for k, v in m.profile(a.steps, parts=True).items():
                if "." in k:
                    times[n].setdefault(k, []).append(v)
    for _ in range(a.repeats):
        for n, m in models.items():
            b = m.arrays.b  # the run is over: the synthetic passes may scribble on it
            lines = (b.shape[1] + LINE_COLUMNS - 1) // LINE_COLUMNS

            def whole(b, lines=lines):
                whole_row(b, lines)

            for name, f in (("one line (memory speed)", one_line), ("whole row (memory speed)", whole)):
                f(b)
                ti.sync()
                t0 = time.perf_counter()
                for _ in range(a.steps):
                    f(b)
                ti.sync()
                times[n].setdefault(name, []).append((time.perf_counter() - t0) / a.steps)
    rows = []
    for n in sizes:
        for k, v in times[n].items():
            ms = statistics.median(v) * 1e3
            rows.append({"n": n, "kernel": k, "ms_per_step": ms, "ns_per_body": ms * 1e6 / n, "repeats": len(v)})
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    with open(out / "row_passes.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        for r in rows:
            w.writerow({k: (f"{v:.4g}" if isinstance(v, float) else v) for k, v in r.items()})
    kernels = [k for k in times[sizes[0]] if all(k in times[n] for n in sizes)]
    print(f"{'kernel':34s}" + "".join(f"{'N=' + str(n):>14s}" for n in sizes) + "   ns per body")
    for k in kernels:
        print(f"{k:34s}" + "".join(f"{statistics.median(times[n][k]) * 1e9 / n:14.1f}" for n in sizes))

    plt = pyplot()
    fig, ax = plt.subplots(figsize=(11, 4.5))
    width = 0.8 / len(sizes)
    for q, n in enumerate(sizes):
        ax.bar(
            [x + q * width for x in range(len(kernels))],
            [statistics.median(times[n][k]) * 1e9 / n for k in kernels],
            width,
            label=f"N = {n:,}",
        )
    ax.set_xticks([x + 0.4 - width / 2 for x in range(len(kernels))])
    ax.set_xticklabels(kernels, rotation=60, ha="right", fontsize=7)
    ax.set_yscale("log")
    ax.set_ylabel("ns per body per step (2 threads)")
    ax.set_title("the parallel form's kernels per body, against passes at memory speed (the last two)")
    ax.grid(axis="y", alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(out / "row_passes.png", dpi=120)


if __name__ == "__main__":
    main()

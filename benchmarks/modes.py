"""Serial against parallel kernels at large N: where ``SERIAL_MAX_N`` should sit.

    python benchmarks/modes.py [N ...] [--out benchmarks/results/modes.csv]

For each N, the active state of ``melange-ti bench scaling`` (a 400-iceberg shelf evolved
for 200 time units, tiled to N) is stepped by a serial-mode and a parallel-mode model on
all hardware threads; the median of 3 blocks of 10 steps is reported in ms per step (the
same timing as ``bench scaling``).
"""

import argparse
import csv
from pathlib import Path

from melange_ti import runtime


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("sizes", nargs="*", type=int, default=[10000, 40000, 100000])
    p.add_argument("--out", type=Path, default=Path("benchmarks/results/modes.csv"))
    a = p.parse_args()
    runtime.init("cpu")
    import taichi as ti

    from melange_ti.bench.common import STATE, evolved_block, paper_scene, tile, time_advance
    from melange_ti.model import SERIAL_MAX_N, Model

    block, _ = evolved_block(400, 200.0)
    rows = []
    for n in a.sizes:
        tiled = tile(block, n)
        row = {"n": n, "threads": ti.lang.impl.current_cfg().cpu_max_num_threads}
        for mode in ("serial", "parallel"):
            m = Model(paper_scene(n), mode=mode)
            m.set_state({k: tiled[k] for k in STATE})
            m.advance(3)  # compiles on first use
            row[f"{mode}_ms_per_step"] = 1e3 * time_advance(m, 10, 3)
        rows.append(row)
        print(f"N = {n:,}: serial {row['serial_ms_per_step']:.2f} ms/step, parallel {row['parallel_ms_per_step']:.2f} ms/step")
    a.out.parent.mkdir(parents=True, exist_ok=True)
    with open(a.out, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    print(f"SERIAL_MAX_N = {SERIAL_MAX_N:,}; results in {a.out}")


if __name__ == "__main__":
    main()

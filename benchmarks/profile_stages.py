"""Per-stage milliseconds per step of the parallel form (``Model.profile``), islands off and on.

    python benchmarks/profile_stages.py --n 100000 --warm 3000 --steps 20
    python benchmarks/profile_stages.py --n 100000 --warm 4500 --steps 20 --islands off --parts
    python benchmarks/profile_stages.py --n 100000 --warm 3000 --islands off --threads 1
    python benchmarks/profile_stages.py --n 100000 --warm 3000 --steps 20 --islands off --groups 1,2 --parts \
        --state /tmp/shelf_100k.npz --csv benchmarks/results/groups/groups_n100000.csv
    python benchmarks/profile_stages.py --n 10000 --warm 3000 --steps 5 --islands on --parts \
        --arch vulkan --state /tmp/shelf_10k.npz --csv benchmarks/results/device/lavapipe_n10000.csv

The paper shelf of ``--n`` icebergs with tilts of 0.05 rad is advanced ``--warm`` steps in
the parallel form, then profiled for ``--steps`` steps with a sync after every stage, with
islands off and on (the same state: both forms give the same bits); ``--parts`` adds a line
per kernel a stage launches (a sync after each). ``--threads`` caps Taichi's CPU threads
(default: all): the same command at 1 and 2 threads shows how well each parallel stage
spreads over the cores.

``--arch vulkan`` profiles the device form (its parallel parts, docs/devices.md); with
``--state FILE.npz`` the warm state is read from FILE if it exists (else computed on the CPU
and written there first, in a child process), so that a slow device is not warmed itself;
the model then takes ``--settle`` steps (default 20) before it is profiled, so that the
profile does not time its arrays' first touches (before that option: about twice the
settled step at N = 100,000).
``--csv`` writes one row per kernel: milliseconds per step, share of the step, and whether
it runs on one thread.
"""

from __future__ import annotations

import argparse


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--n", type=int, default=100000)
    p.add_argument("--warm", type=int, default=3000)
    p.add_argument("--steps", type=int, default=20)
    p.add_argument("--islands", choices=("off", "on", "both"), default="both")
    p.add_argument("--parts", action="store_true")
    p.add_argument("--threads", type=int, default=None)
    p.add_argument("--arch", default="cpu", choices=("cpu", "gpu", "cuda", "vulkan"))
    p.add_argument("--state", help="npz file of the warm state (read if present, else written)")
    p.add_argument("--settle", type=int, default=20, help="steps after reading --state, before profiling")
    p.add_argument("--csv", help="write the per-kernel profile (with --parts) to this CSV file")
    p.add_argument(
        "--groups",
        default="auto",
        help="islands off: contiguous groups of the sequential passes, 'auto' (one per thread) or a list, e.g. 1,2",
    )
    a = p.parse_args()
    import subprocess
    import sys
    from pathlib import Path

    import numpy as np

    from melange_ti import runtime, scene

    if a.state and a.arch != "cpu" and not Path(a.state).exists():
        warm = [sys.executable, __file__, "--n", str(a.n), "--warm", str(a.warm), "--steps", "0", "--state", a.state]
        subprocess.run([*warm, "--islands", "off"], check=True)
    runtime.init(a.arch, threads=a.threads, precision="f64")
    from melange_ti.model import Model
    from melange_ti.physics import stages

    sc = scene.load(None, overrides=[("shelf.count", a.n), ("shelf.tilt", 0.05)])
    one_thread = {
        f"{st.name}.{part.func.__name__}": part.sequential
        for st in stages.STAGES
        for parts in (st.parallel, st.without_islands or (), st.device or (), st.groups or ())
        for part in parts
    }
    rows = []
    group_counts = [None] if a.groups == "auto" else [int(g) for g in a.groups.split(",")]
    wanted = {"off": (False,), "on": (True,), "both": (False, True)}[a.islands]
    forms = [(False, g) for g in group_counts] + [(True, None)]
    for islands, groups in [(isl, g) for isl, g in forms if isl in wanted]:
        m = Model(sc, mode="parallel", islands=islands, groups=groups)
        if a.state and Path(a.state).exists():
            m.set_state(dict(np.load(a.state)))
            # a fresh model's first steps touch its arrays' pages for the first time and
            # fill its candidate lists: 58 against 25-31 ms/step at N = 100,000 (t = 45)
            m.advance(a.settle)
        else:
            m.advance(a.warm)
            if a.state:
                np.savez(a.state, **m.state())
        if a.steps == 0:
            continue
        prof = m.profile(a.steps, parts=a.parts)
        stage = {k: v for k, v in prof.items() if "." not in k}
        total = sum(stage.values())
        cells = ", ".join(f"{k} {v * 1e3:.2f}" for k, v in stage.items())
        form = "islands on " if islands else f"islands off, {m.groups} group{'s' if m.groups > 1 else ''}"
        print(f"{runtime.backend()}, {form}: {cells}; total {total * 1e3:.1f} ms/step", flush=True)
        for k, v in prof.items():
            if "." in k:
                flag = "  one thread" if one_thread.get(k) else ""
                print(f"    {k:32s} {v * 1e3:8.2f} ms/step {v / total:7.1%}{flag}", flush=True)
                rows.append((runtime.backend(), a.n, int(islands), m.groups, k, v * 1e3, v / total, int(bool(one_thread.get(k)))))
    if a.csv and rows:
        Path(a.csv).parent.mkdir(parents=True, exist_ok=True)
        with open(a.csv, "w") as f:
            f.write("backend,n,islands,groups,kernel,ms_per_step,share,one_thread\n")
            for r in rows:
                f.write(f"{r[0]},{r[1]},{r[2]},{r[3]},{r[4]},{r[5]:.4f},{r[6]:.4f},{r[7]}\n")


if __name__ == "__main__":
    main()

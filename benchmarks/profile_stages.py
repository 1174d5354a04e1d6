"""Per-stage milliseconds per step of the parallel form (``Model.profile``), islands off and on.

    python benchmarks/profile_stages.py --n 100000 --warm 3000 --steps 20
    python benchmarks/profile_stages.py --n 100000 --warm 4500 --steps 20 --islands off --parts
    python benchmarks/profile_stages.py --n 100000 --warm 3000 --islands off --threads 1

The paper shelf of ``--n`` icebergs with tilts of 0.05 rad is advanced ``--warm`` steps in
the parallel form, then profiled for ``--steps`` steps with a sync after every stage, with
islands off and on (the same state: both forms give the same bits); ``--parts`` adds a line
per kernel a stage launches (a sync after each). ``--threads`` caps Taichi's CPU threads
(default: all): the same command at 1 and 2 threads shows how well each parallel stage
spreads over the cores.
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
    a = p.parse_args()
    from melange_ti import runtime, scene

    runtime.init("cpu", threads=a.threads, precision="f64")
    from melange_ti.model import Model

    sc = scene.load(None, overrides=[("shelf.count", a.n), ("shelf.tilt", 0.05)])
    for islands in {"off": (False,), "on": (True,), "both": (False, True)}[a.islands]:
        m = Model(sc, mode="parallel", islands=islands)
        m.advance(a.warm)
        prof = m.profile(a.steps, parts=a.parts)
        stage = {k: v for k, v in prof.items() if "." not in k}
        cells = ", ".join(f"{k} {v * 1e3:.2f}" for k, v in stage.items())
        print(f"islands {'on ' if islands else 'off'}: {cells}; total {sum(stage.values()) * 1e3:.1f} ms/step", flush=True)
        for k, v in prof.items():
            if "." in k:
                print(f"    {k:32s} {v * 1e3:6.2f} ms/step", flush=True)


if __name__ == "__main__":
    main()

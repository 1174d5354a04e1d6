"""Largest stable dt of the paper scene: run it at growing dt and watch for blow-up.

    python validation/stability.py [--count 100] [--time 400]

For each dt the paper scene (``shelf.count`` icebergs) runs ``--time`` time units; it is
stable if the state stays finite and the total energy never rises above its start.
"""

import argparse

import numpy as np

from melange_ti import runtime
from melange_ti import scene as scn


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--count", type=int, default=100)
    p.add_argument("--time", type=float, default=400.0)
    a = p.parse_args()
    runtime.init("cpu", threads=1)
    from melange_ti.model import Model

    for dt in (0.01, 0.02, 0.04, 0.08, 0.16, 0.32):
        sc = scn.load(
            None,
            [
                ("shelf.count", a.count),
                ("time.dt", dt),
                ("output.diagnostic_interval", 3.2),
                ("output.snapshot_interval", 32.0),
                ("output.checkpoint_interval", 320.0),
            ],
        )
        m = Model(sc)
        s0 = m.sample()
        e0 = s0["kinetic"].sum() + s0["potential"].sum()
        rise, finite = -np.inf, True
        for _ in range(20):
            m.advance(round(a.time / 20 / dt))
            s = m.sample()
            e = s["kinetic"].sum() + s["potential"].sum()
            finite = finite and bool(np.isfinite(e))
            rise = max(rise, e - e0)
        print(f"dt={dt:<5} finite={finite} largest energy rise above start={rise:+.3g} stable={finite and rise <= 0}", flush=True)


if __name__ == "__main__":
    main()

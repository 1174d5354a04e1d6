"""Energy-budget residual of the paper scene against dt (SPEC section 5: it must shrink).

    python validation/energy_residual.py [--count 100] [--time 200] [--out validation/results]

Runs the paper scene (``shelf.count`` icebergs) for ``--time`` time units at dt = 0.02, 0.01,
0.005, 0.0025 and writes ``energy_residual.csv``: released energy E(0) - E(t), the booked
dissipation (every energy ledger of the budget, ``diagnostics.ENERGY_LEDGERS``) and the residual
between them.
"""

import argparse
import csv
from pathlib import Path

from melange_ti import runtime
from melange_ti import scene as scn
from melange_ti.diagnostics import ENERGY_LEDGERS
from melange_ti.energy import total_energy


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--count", type=int, default=100)
    p.add_argument("--time", type=float, default=200.0)
    p.add_argument("--out", default="validation/results")
    a = p.parse_args()
    runtime.init("cpu", threads=1)
    from melange_ti.model import Model

    rows = []
    for dt in (0.02, 0.01, 0.005, 0.0025):
        sc = scn.load(None, [("shelf.count", a.count), ("time.dt", dt)])
        m = Model(sc)
        s0 = m.sample()
        e0 = total_energy(s0)
        m.advance(round(a.time / dt))
        s = m.sample()
        tot = m.totals()
        released = e0 - total_energy(s)
        booked = sum(float(s[k].sum()) if k in s else getattr(tot, k) for k in ENERGY_LEDGERS)
        rows.append(
            {
                "dt": dt,
                "released": released,
                "dissipated": booked,
                "residual": released - booked,
                "residual_fraction": (released - booked) / released,
            }
        )
        print(
            f"dt={dt:<7} released={released:.5f} dissipated={booked:.5f} residual={released - booked:+.2e} "
            f"({(released - booked) / released:+.2%})",
            flush=True,
        )
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    with open(out / "energy_residual.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)


if __name__ == "__main__":
    main()

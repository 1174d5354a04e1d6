"""Coloured against sequential contact passes (issue #34): the paper's statistics over time.

    melange-ti ensemble runs/paper.toml --seeds 8 --set contacts.order=sequential,coloured \\
        --set time.duration=2000 --set output.snapshot_interval=50 --out ens_order --workers 2
    melange-ti plot ens_order --out runs/paper_order
    python validation/contact_order.py ens_order

The order of impulses in a dense pack is a modelling choice: both orders are Gauss-Seidel
passes of the same contact law. For the capsized fraction, the leading edge and the released
potential energy, at every diagnostic time, the two groups' means (8 seeds each) and their
standard deviations over seeds; the largest difference of the means over time as a multiple
of the seeds' spread (the larger of the two standard deviations at that time, where it is
not zero). Writes ``validation/results/contact_order.csv`` (the series) and prints a summary;
the figures are ``melange-ti plot``'s (``runs/paper_order``).
"""

import argparse
import csv
import sys
from pathlib import Path

import numpy as np

from melange_ti.analysis.runs import load_run, make_groups

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "validation" / "results" / "contact_order.csv"
QUANTITIES = {"capsized_fraction": "capsized fraction", "leading_edge": "leading edge", "released": "released energy"}


def series(group, name: str):
    if name == "released":
        runs = group.runs
        t = runs[0].diag["time"]
        values = []
        for r in runs:
            p = r.diag["potential_energy"]
            values.append(np.interp(t, r.diag["time"], p[0] - p))
        v = np.array(values)
        return t, v.mean(axis=0), v.std(axis=0)
    ens = group.series(name)
    return ens.time, ens.mean, ens.std


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("folder", help="the ensemble's folder (order=sequential_seedK.h5, order=coloured_seedK.h5)")
    p.add_argument("--csv", default=str(OUT))
    a = p.parse_args()
    runs = [load_run(f) for f in sorted(Path(a.folder).glob("*.h5"))]
    groups = {g.runs[0].scene.contacts.order: g for g in make_groups(runs, ["contacts.order"])}
    if set(groups) != {"sequential", "coloured"}:
        print(f"expected the two orders, found {sorted(groups)}", file=sys.stderr)
        return 2
    rows = {}
    worst = {}
    for name, label in QUANTITIES.items():
        t, ms, ss = series(groups["sequential"], name)
        tc, mc, sc = series(groups["coloured"], name)
        mc, sc = np.interp(t, tc, mc), np.interp(t, tc, sc)
        spread = np.maximum(ss, sc)
        ratio = np.where(spread > 0, np.abs(mc - ms) / np.where(spread > 0, spread, 1.0), 0.0)
        k = int(np.argmax(ratio))
        worst[label] = (float(ratio[k]), float(t[k]), float(np.mean(ratio[t > 0])))
        for q, tq in enumerate(t):
            rows.setdefault(float(tq), {"time": float(tq)}).update(
                {
                    f"{name}_sequential": ms[q],
                    f"{name}_sequential_sd": ss[q],
                    f"{name}_coloured": mc[q],
                    f"{name}_coloured_sd": sc[q],
                }
            )
    out = Path(a.csv)
    out.parent.mkdir(parents=True, exist_ok=True)
    table = [rows[t] for t in sorted(rows)]
    with open(out, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(table[0]))
        w.writeheader()
        for r in table:
            w.writerow({k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in r.items()})
    seeds = {o: len(g.runs) for o, g in groups.items()}
    print(f"{seeds['sequential']} sequential and {seeds['coloured']} coloured runs, t <= {table[-1]['time']:g}; {out}")
    for label, (r, t, mean) in worst.items():
        print(f"{label}: |difference of the means| at most {r:.2f} of the seeds' spread (at t = {t:g}), {mean:.2f} on average")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

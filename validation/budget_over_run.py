"""The energy budget's largest residual over a run, with every effect, at the default time step
and half of it (docs/model.md, "What the budget promises"; docs/validation.md, "The budget at
every instant").

    python validation/budget_over_run.py [--out validation/results] [--quick]

Each case runs through ``melange_ti.run`` into a run file; the budget is read from the file's
diagnostics as a user reads it (``melange_ti.energy.budget_series``): ``residual = E(0) - E(t)
- ledgers(t)``. Reported: the residual of largest magnitude over the run (and its time) over
the largest energy released over the run, ``max_t |residual| / max_t released``, the end's,
and, for the paper scenes, the same over t <= 200 and t <= 1000 of the one run to 8000 (an
offset stays put as the run goes on; a drift grows with it). The cases:

- ``lone``: one upright 1 x 1.6 block tilted 0.01 rad, gravity and buoyancy alone (it capsizes
  and rocks on undamped), t <= 100;
- ``lone_waves``: the same over water 4 deep with ``waves`` (the sea to x = 120), the default
  wave step;
- ``pair_breaking``: two such blocks bonded face to face (stable together), tilted 0.02 rad, a
  weak bond (strength 0.0005) that breaks, after which both capsize; drag 0.01, t <= 80;
- ``paper``, ``paper_waves``, ``paper_friction``: ``runs/paper.toml``, ``runs/paper_waves.toml``,
  ``runs/paper_friction.toml`` (400 icebergs), t <= 8000 at the default step, t <= 1000 at
  half of it;
- ``paper_polygons``: the paper scene's shelf cut at 0.2 rad from the vertical, with a spread
  of 0.05 rad: 400 quadrilaterals, t <= 1000.

Writes ``budget_over_run.csv``. ``--quick``: the three small cases only (seconds once the
kernels are compiled); ``--case NAME``: that case only, the CSV's other rows kept.
"""

from __future__ import annotations

import argparse
import csv
import tempfile
from pathlib import Path

import numpy as np

import melange_ti as mt
from melange_ti import scene as scn
from melange_ti.energy import budget_series
from melange_ti.io.hdf5 import read_diagnostics

R = scn.DENSITY_RATIO
ROOT = Path(__file__).resolve().parent.parent
H = 1.6  # the lone block's thickness: unstable upright (critical aspect 1.30)
Z = -R * H + H / 2  # its floating height


def lone(dt: float, waves: bool = False) -> scn.Scene:
    effects = '["gravity", "buoyancy", "waves"]' if waves else '["gravity", "buoyancy"]'
    water = "[physics]\nwater_depth = 4.0\nwave_end = 120.0\n" if waves else ""
    return scn.loads(
        f'[scene]\nname = "lone"\neffects = {effects}\n{water}'
        f"[time]\ndt = {dt}\nduration = 100.0\n[output]\ndiagnostic_interval = 0.1\nsnapshot_interval = 10.0\n"
        f"[[iceberg]]\nx = 60.0\nz = {Z}\ntheta = 0.01\nthickness = {H}\n"
    )


def pair_breaking(dt: float) -> scn.Scene:
    return scn.loads(
        '[scene]\nname = "pair_breaking"\neffects = ["gravity", "buoyancy", "drag", "collisions", "wall", "bonds"]\n'
        "[physics]\ndrag = 0.01\ntensile_strength = 0.0005\nshear_strength = 0.0005\n"
        f"[time]\ndt = {dt}\nduration = 80.0\n[output]\ndiagnostic_interval = 0.1\nsnapshot_interval = 10.0\n"
        f"[[iceberg]]\nx = 20.0\nz = {Z}\ntheta = 0.02\nthickness = {H}\n"
        f"[[iceberg]]\nx = 21.0\nz = {Z}\ntheta = 0.02\nthickness = {H}\n[[bond]]\na = 0\nb = 1\n"
    )


def paper(name: str, dt: float, duration: float, extra: tuple = ()) -> scn.Scene:
    return scn.load(ROOT / "runs" / f"{name}.toml", [("time.dt", dt), ("time.duration", duration), *extra])


def cases(quick: bool):
    yield "lone", 0.01, lambda dt: lone(dt)
    yield "lone_waves", 0.01, lambda dt: lone(dt, waves=True)
    yield "pair_breaking", 0.01, pair_breaking
    if quick:
        return
    for name in ("paper", "paper_waves", "paper_friction"):
        yield name, 0.01, lambda dt, name=name: paper(name, dt, 8000.0 if dt == 0.01 else 1000.0)
    cut = (("shelf.cut_tilt", 0.2), ("shelf.cut_tilt_std", 0.05))
    yield "paper_polygons", 0.01, lambda dt: paper("paper", dt, 1000.0, cut)


def measure(sc: scn.Scene, out: Path) -> dict:
    mt.run(sc, out, overwrite=True, progress=False)
    b = budget_series(read_diagnostics(out))
    t, res, rel = b["time"], b["residual"], b["released"]
    row = {}
    for horizon in (200.0, 1000.0, float("inf")):
        keep = t <= horizon + 1e-9
        if horizon != float("inf") and t[-1] <= horizon:
            continue
        k = int(np.argmax(np.abs(res[keep])))
        tag = "" if horizon == float("inf") else f"_t{horizon:g}"
        row[f"largest{tag}"] = float(abs(res[keep][k]) / np.max(np.abs(rel[keep])))
        if not tag:
            row["at_t"] = float(t[keep][k])
    row["end"] = float(res[-1] / np.max(np.abs(rel)))
    row["released_largest"] = float(np.max(np.abs(rel)))
    row["duration"] = float(t[-1])
    return row


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", default="validation/results")
    p.add_argument("--quick", action="store_true", help="the three small cases only")
    p.add_argument("--case", action="append", help="run only this case (again for more); the CSV keeps the others' rows")
    a = p.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name, dt0, make in cases(a.quick):
            if a.case and name not in a.case:
                continue
            for dt in (dt0, dt0 / 2):
                r = {"case": name, "dt": dt, **measure(make(dt), Path(tmp) / f"{name}.h5")}
                rows.append(r)
                print(
                    f"{name:15s} dt={dt:<6g} t<={r['duration']:<6g} largest {r['largest']:.2e} at t={r['at_t']:g}"
                    + "".join(f", {k} {r[k]:.2e}" for k in ("largest_t200", "largest_t1000") if k in r)
                    + f", end {r['end']:+.2e}",
                    flush=True,
                )
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    names = ["case", "dt", "duration", "released_largest", "largest", "at_t", "largest_t200", "largest_t1000", "end"]
    if a.case and (out / "budget_over_run.csv").exists():  # the other cases' rows, as they were
        with open(out / "budget_over_run.csv", newline="") as fh:
            kept = [r for r in csv.DictReader(fh) if r["case"] not in a.case]
        order = [n for n, _, _ in cases(False)]
        rows = sorted(kept + rows, key=lambda r: (order.index(r["case"]), -float(r["dt"])))
    with open(out / "budget_over_run.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=names, restval="")
        w.writeheader()
        w.writerows({k: r.get(k, "") for k in names} for r in rows)


if __name__ == "__main__":
    main()

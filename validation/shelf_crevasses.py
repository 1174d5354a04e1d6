"""Shelf to melange through a crevasse field (issue 50, item 7 in part): the strength below which
the front's capsize breaks up an intact shelf, against the depth of its surface crevasses.

    python validation/shelf_crevasses.py --out validation/results/shelf_crevasses   # 164 runs, ~8 min on one core

``runs/shelf_breakup.toml`` at N = 50 to t = 1000 (the scan of ``validation/shelf_breakup.py``),
every joint a surface crevasse open over ``d`` of the thickness (``shelf.crevasse_depth``; the
joint's bond holds the ligament below it, docs/bonds.md "Crevasses"), for ``d`` = 0, 0.25, 0.5,
0.75 and 0.9, at strengths ``S = s / (1 - d)^2`` for ``s`` in ``--scaled``, seeds 1-4, and the
limit ``d = 1``: the paper's pre-cut row (no bonds). Why ``(1 - d)^2``: a ligament of
``(1 - d) t`` under a moment ``M`` carries ``6 M / ((1 - d) t)^2``, so if the capsize puts the
same moment on the joints the critical strength scales so, and ``s`` is the same at every
depth. Each run's end state as in ``shelf_breakup.py`` (its ``end_state``), with the depth.
Writes ``crevasses.csv`` and ``crevasses.png``; with ``--crushing`` (ice crushing at the contacts,
the effect's defaults) ``crevasses_crush.csv`` and ``.png``.
"""

from __future__ import annotations

import argparse
import csv
import sys
import time
from pathlib import Path

import numpy as np

import melange_ti as mt

sys.path.insert(0, str(Path(__file__).resolve().parent))
import shelf_breakup  # noqa: E402  (this folder's study: its end state, and its contact law)
from shelf_breakup import PA, SCENE, end_state  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def one(depth: float, strength: float | None, seed: int, work: Path, count: int = 50, duration: float = 1000.0) -> dict:
    over = {"shelf.count": count, "time.duration": duration, "time.seed": seed, "shelf.crevasse_depth": depth}
    if strength is not None:
        over |= {"physics.tensile_strength": strength, "physics.shear_strength": strength}
    over |= shelf_breakup.variant(SCENE)  # --crushing
    out = work / f"crev_{depth:g}_{strength}_{seed}{shelf_breakup.suffix(0)}.h5"
    t0 = time.time()
    mt.run(mt.load_scene(SCENE, overrides=over), out=out, overwrite=True, threads=1)
    row = {"crevasse_depth": depth, "strength": strength if strength is not None else "", "seed": seed}
    row |= {"scaled": strength * (1 - depth) ** 2 if strength is not None else ""}
    row |= {k: v for k, v in end_state(out).items() if k not in ("t_half", "t_cross")}
    row["wall_s"] = round(time.time() - t0, 1)
    out.unlink()
    out.with_name(out.name + ".ckpt").unlink(missing_ok=True)
    print(" ".join(f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}" for k, v in row.items()), flush=True)
    return row


def broke(r: dict) -> bool:
    """The shelf broke: more than the front capsized, or under 90% of its bonds intact."""
    return float(r["capsized"]) > 1.5 / 50 or (r["bonds_intact"] != "" and float(r["bonds_intact"]) < 0.9)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", type=Path, default=ROOT / "validation" / "results" / "shelf_crevasses")
    p.add_argument("--depths", default="0,0.25,0.5,0.75,0.9")
    p.add_argument("--scaled", default="0.05,0.07,0.1,0.13,0.17,0.2,0.3,0.5", help="S (1 - d)^2 values")
    p.add_argument("--seeds", default="1,2,3,4")
    p.add_argument("--add", action="store_true", help="keep the rows of crevasses.csv already there (a scan extended)")
    p.add_argument(
        "--crushing",
        action="store_true",
        help="ice crushing at the contacts (effect crushing, its defaults): crevasses_crush.csv, .png",
    )
    a = p.parse_args()
    shelf_breakup.VARIANT["crushing"] = a.crushing
    name = "crevasses_crush" if a.crushing else "crevasses"
    a.out.mkdir(parents=True, exist_ok=True)
    depths = [float(v) for v in a.depths.split(",")]
    scaled = [float(v) for v in a.scaled.split(",")]
    seeds = [int(v) for v in a.seeds.split(",")]
    rows = []
    old = a.out / f"{name}.csv"
    if a.add and old.exists():
        with open(old) as fh:
            for r in csv.DictReader(fh):
                r["crevasse_depth"], r["seed"] = float(r["crevasse_depth"]), int(r["seed"])
                rows.append(r)
    done = {(r["crevasse_depth"], str(r["strength"]), r["seed"]) for r in rows}
    work = a.out / "runs"
    work.mkdir(exist_ok=True)
    for seed in seeds:
        if (1.0, "", seed) not in done:
            rows.append(one(1.0, None, seed, work))  # cut through: the pre-cut row
        for d in depths:
            for s in scaled:
                if (d, str(s / (1 - d) ** 2), seed) not in done:
                    rows.append(one(d, s / (1 - d) ** 2, seed, work))
    work.rmdir()
    rows.sort(key=lambda r: (r["seed"], r["crevasse_depth"], float(r["strength"] or 0)))
    with open(a.out / f"{name}.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4.2))
    shown = sorted({r["crevasse_depth"] for r in rows if r["strength"] != ""})  # every depth in the CSV, not only this call's
    highest = {}
    for seed, mk in zip(sorted({r["seed"] for r in rows}), "os^D", strict=False):
        hi = []
        for d in shown:
            b = [float(r["strength"]) for r in rows if r["seed"] == seed and r["crevasse_depth"] == d and broke(r)]
            hi.append(max(b) if b else np.nan)
        highest[seed] = hi
        a1.plot(shown, hi, mk + "-", mfc="none", label=f"seed {seed}")
    d = np.linspace(0, 0.9, 50)
    ref = np.nanmedian([hi[0] for hi in highest.values()]) if shown and shown[0] == 0 else np.nan  # the seeds' median at d = 0
    a1.plot(d, ref / (1 - d) ** 2, "k--", lw=1, label="(1 - d)^-2 from d = 0")
    a1.set(yscale="log", xlabel="crevasse depth d (fraction of the thickness)", ylabel="highest strength that broke (rho_w g w)")
    a1.legend(fontsize=7)
    a1.grid(alpha=0.3, which="both")
    for d_, c in zip(shown, ("k", "C0", "C1", "C2", "C3", "C4"), strict=False):
        mine = [r for r in rows if r["crevasse_depth"] == d_ and r["strength"] != ""]
        pts = sorted((float(r["scaled"]), float(r["capsized"])) for r in mine)
        a2.plot(*zip(*pts, strict=True), "o", color=c, mfc="none", ms=4, label=f"d = {d_:g}")
    pre = [float(r["capsized"]) for r in rows if r["crevasse_depth"] == 1.0]
    a2.axhline(float(np.mean(pre)), color="k", ls=":", label=f"d = 1: the pre-cut row ({np.mean(pre):.2f})")
    a2.set(xscale="log", xlabel="S (1 - d)^2 (rho_w g w)", ylabel="capsized fraction at t = 1000")
    a2.legend(fontsize=7)
    a2.grid(alpha=0.3, which="both")
    top = a1.secondary_yaxis("right", functions=(lambda s: s * PA / 1e3, lambda k: k * 1e3 / PA))
    top.set_ylabel("kPa at w = 70 m")
    title = "an intact shelf of 50 pieces through a field of surface crevasses: where the front's capsize breaks it"
    if a.crushing:
        title += " (ice crushing at the contacts)"
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(a.out / f"{name}.png", dpi=120)


if __name__ == "__main__":
    main()

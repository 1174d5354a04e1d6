"""Shelf to melange (issue #31): the tensile strength below which a capsize breaks up an intact shelf.

    python validation/shelf_breakup.py scan  [--count 50] [--duration 1000] [--cut-tilt DEG]   # log sweep, cheap
    python validation/shelf_breakup.py sweep [--count 400] [--duration 2000] [--strengths ...] [--seeds 1,2]
    python validation/shelf_breakup.py seeds [--count 400] [--duration 2000] --strength S [--seeds 1,...,8]
    python validation/shelf_breakup.py table                                   # the CSVs again from the run files
    python validation/shelf_breakup.py plot                                    # phase.png from the CSVs
    python validation/shelf_breakup.py cuts                                    # cuts.png from the scans' CSVs

``runs/shelf_breakup.toml`` (the paper's icebergs as one bonded shelf, the first bonded to the
wall, only the seaward one free and tilted) at ``physics.tensile_strength = shear_strength = S``
(Weibull modulus 5 about it, drawn from ``time.seed``), one run at a time on one thread, against
the paper's pre-cut scene (``runs/paper.toml``, same count and duration). Each run's end state
is a row: capsized fraction (the model's: a polygon's principal axis), leading edge, pieces
(``fragments``), the fraction of bonds intact, the released energy and the budget's residual
relative to it, ``depth`` (how far into the shelf, in icebergs from its seaward end, the deepest
capsized iceberg started), and three times: the last bond's break, and when the capsize front
reached the middle of the shelf and its inner tenth (the first snapshot where an iceberg that
started there or deeper has capsized; empty: never), and ``capsized_v``, the fraction whose body
v axis (vertical in the shelf) is past 45 degrees at the end (the measure of ``depth`` and the
times; the model's own for rectangles). ``scan`` writes ``scan.csv``,
``sweep`` ``sweep.csv`` (plus ``phase.png``), ``seeds`` ``seeds.csv``, all in
``validation/results/shelf_breakup/``; the run files go to ``runs/shelf_breakup/`` (not kept).

``--cut-tilt DEG`` (any mode but ``table``, ``plot``, ``cuts``; default 0: vertical cuts) cuts the shelf
by faces leaning ``DEG`` degrees, top seaward for ``DEG > 0``, with a normal spread of 2.5 degrees
(``shelf.cut_tilt``, ``shelf.cut_tilt_std``; the pieces are parallelograms bonded across the cuts, as
in ``validation/shelf_cuts.py``). The tilt is the rows' last column, ``cut_tilt_deg``, and a suffix
of the run files and CSVs (``scan_cut20.csv``); ``cuts`` plots the scans of every tilt (``cuts.png``).
"""

import argparse
import csv
import math
import re
import sys
import time
from pathlib import Path

import h5py
import numpy as np

import melange_ti as mt
from melange_ti.analysis import stats
from melange_ti.diagnostics import capsized
from melange_ti.physics.effects import REGISTRY
from melange_ti.physics.effects.bonds import pascals

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "runs" / "shelf_breakup.toml"
PAPER = ROOT / "runs" / "paper.toml"
OUT = ROOT / "validation" / "results" / "shelf_breakup"
RUNS = ROOT / "runs" / "shelf_breakup"
PA = pascals(70.0)  # the stress unit at w = 70 m
INNER = 0.1  # the front has crossed when an iceberg of the inner tenth (by start position) capsizes
CUT_STD = 2.5  # degrees: the spread of the cuts' tilts about --cut-tilt
COLUMNS = (
    "scene", "count", "duration", "strength", "strength_MPa", "seed", "capsized", "leading_edge", "fragments",
    "bonds_intact", "released", "residual", "residual_rel", "depth", "t_last_break", "t_half", "t_cross", "wall_s", "steps_per_s",
    "capsized_v", "cut_tilt_deg",
)  # fmt: skip


def end_state(path: Path) -> dict:
    """One run file's end state (see the module docstring)."""
    with h5py.File(path, "r") as f:
        d = {k: f["diagnostics"][k][:] for k in f["diagnostics"]}
        x, th, ts = f["snapshots/x"][:], f["snapshots/theta"][:], f["snapshots/time"][:]
        broken = f["bonds/break_time"][:] if "bonds" in f else np.zeros(0)
    budget = stats.energy_budget(d)
    n = x.shape[1]
    rank = np.argsort(np.argsort(-x[0])) / n  # 0: the seaward iceberg, near 1: the one at the wall
    caps = capsized(th)

    def reached(depth: float):
        """The first snapshot time an iceberg that started ``depth`` into the shelf or deeper has capsized."""
        k = np.flatnonzero(np.any(caps & (rank >= depth), axis=1))
        return float(ts[k[0]]) if k.size else ""

    bonds = d.get("bonds_intact")
    last = broken[np.isfinite(broken) & (broken >= 0)] if broken.size else broken
    return {
        "capsized": float(d["capsized_fraction"][-1]),
        "leading_edge": float(d["leading_edge"][-1]),
        "fragments": int(d["fragments"][-1]) if "fragments" in d else n,  # without bonds: each iceberg its own piece
        "bonds_intact": float(bonds[-1] / bonds[0]) if bonds is not None and bonds[0] > 0 else "",
        "released": float(budget["released"][-1]),
        "residual": float(budget["residual"][-1]),
        "residual_rel": float(budget["residual"][-1] / budget["released"][-1]),
        "t_last_break": float(last.max()) if last.size else "",
        "depth": float(np.max(rank[caps[-1]]) * n + 1) if caps[-1].any() else 0.0,
        "t_half": reached(0.5),
        "t_cross": reached(1 - INNER),
        "capsized_v": float(caps[-1].mean()),
    }


# the contact law and resolution of a study (``--crushing``, ``--dt``, ``--discs``): None is the scene's
VARIANT = {"crushing": False, "pressure": None, "dt": None, "discs": None, "count": None}


def suffix(cut_tilt) -> str:
    """``_cut20`` for cuts leaning 20 degrees, then ``_crush`` with ice crushing at the contacts,
    ``_dt0.005`` and ``_d56`` for another time step or disc count; empty for vertical cuts at the
    scene's own (the file names of before)."""
    deg = float(cut_tilt or 0)
    out = f"_cut{deg:g}" if deg else ""
    if VARIANT["crushing"]:
        out += "_crush"
    if VARIANT["pressure"] is not None:
        out += f"_p{VARIANT['pressure']:g}"
    if VARIANT["dt"] is not None:
        out += f"_dt{VARIANT['dt']:g}"
    if VARIANT["discs"] is not None:
        out += f"_d{VARIANT['discs']}"
    if VARIANT["count"] is not None:  # a crushing scan of another shelf length (the run files name it already)
        out += f"_n{VARIANT['count']}"
    return out


def run_path(tag: str, count, strength, seed, cut_tilt=0.0) -> Path:
    return RUNS / f"{tag}_n{count}_s{strength if strength not in (None, '') else 'cut'}_seed{seed}{suffix(cut_tilt)}.h5"


def csv_name(base: str, cut_tilt=0.0) -> str:
    return f"{base}{suffix(cut_tilt)}.csv"


def one(
    scene_path: Path, tag: str, count: int, duration: float, seed: int, strength: float | None, cut_tilt: float = 0.0
) -> dict:
    over = {"shelf.count": count, "time.duration": duration, "time.seed": seed}
    if strength is not None:
        over |= {"physics.tensile_strength": strength, "physics.shear_strength": strength}
    if cut_tilt:
        over |= {"shelf.cut_tilt": math.radians(cut_tilt), "shelf.cut_tilt_std": math.radians(CUT_STD)}
    over |= variant(scene_path)
    RUNS.mkdir(parents=True, exist_ok=True)
    out = run_path(tag, count, strength, seed, cut_tilt)
    t0 = time.time()
    r = mt.run(mt.load_scene(scene_path, overrides=over), out=out, overwrite=True, threads=1)
    row = {
        "scene": tag,
        "count": count,
        "duration": duration,
        "strength": strength if strength is not None else "",
        "strength_MPa": strength * PA / 1e6 if strength is not None else "",
        "seed": seed,
        **end_state(out),
        "wall_s": round(time.time() - t0, 1),
        "steps_per_s": round(r.steps_per_second),
        "cut_tilt_deg": cut_tilt,
    }
    print(" ".join(f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}" for k, v in row.items()), flush=True)
    return row


def variant(scene_path: Path) -> dict:
    """The scene overrides of :data:`VARIANT`: ``crushing`` added to the scene's effects (the
    pre-cut reference too: its contacts crush alike), the step and the disc count."""
    over = {}
    if VARIANT["crushing"]:
        named = mt.load_scene(scene_path).effects
        over["scene.effects"] = [e.name for e in REGISTRY if getattr(named, e.name)] + ["crushing"]
        if VARIANT["pressure"] is not None:
            over["physics.crushing_pressure"] = VARIANT["pressure"]
    if VARIANT["dt"] is not None:
        over["time.dt"] = VARIANT["dt"]
    if VARIANT["discs"] is not None:
        over["contacts.discs"] = VARIANT["discs"]
    return over


def write(rows: list[dict], name: str) -> None:
    OUT.mkdir(parents=True, exist_ok=True)
    with open(OUT / name, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=COLUMNS)
        w.writeheader()
        w.writerows(rows)


def read(name: str) -> list[dict]:
    p = OUT / name
    if not p.exists():
        return []
    with open(p) as fh:
        return list(csv.DictReader(fh))


def plot() -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows, scan = read("sweep.csv"), read("scan.csv")
    bonded = [r for r in rows if r["scene"] == "shelf_breakup"]
    paper = [r for r in rows if r["scene"] == "paper"]
    fig, axes = plt.subplots(2, 1, figsize=(7.5, 7.5), sharex=True, layout="constrained")
    for ax, key, label in zip(
        axes, ("capsized", "leading_edge"), ("capsized fraction at the end", "leading edge at the end (w)"), strict=True
    ):
        for seed, marker in zip(sorted({r["seed"] for r in bonded}), "os^Dv<>p", strict=False):
            pts = [(float(r["strength"]), float(r[key])) for r in bonded if r["seed"] == seed]
            if pts:
                n = bonded[0]["count"]
                ax.plot(*zip(*pts, strict=True), marker, ms=6, mfc="none", label=f"bonded shelf, N = {n}, seed {seed}")
        if scan and key == "capsized":
            pts = [(float(r["strength"]), float(r[key])) for r in scan]
            ax.plot(
                *zip(*pts, strict=True),
                "x",
                color="0.5",
                label=f"bonded shelf, N = {scan[0]['count']} (scan, t = {float(scan[0]['duration']):g})",
            )
        for r, ls in zip(paper, ("-", "--", ":", "-."), strict=False):
            ax.axhline(float(r[key]), color="k", ls=ls, lw=1, label=f"paper scene, pre-cut (gap 0.1), seed {r['seed']}")
        ax.set_xscale("log")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3, which="both")
    axes[-1].set_xlabel("tensile strength = shear strength (rho_w g w); Weibull modulus 5 about it")
    top = axes[0].secondary_xaxis("top", functions=(lambda s: s * PA / 1e6, lambda m: m * 1e6 / PA))
    top.set_xlabel("MPa at w = 70 m")
    axes[0].legend(fontsize=7)
    dur = float(rows[0]["duration"]) if rows else float("nan")
    fig.suptitle(f"Shelf to mélange: the intact shelf's end state (t = {dur:g}) against its bonds' strength", fontsize=10)
    fig.savefig(OUT / "phase.png", dpi=120)
    print(f"wrote {OUT / 'phase.png'}")


def cuts() -> None:
    """cuts.png: the scans of every cut tilt (``scan.csv``, ``scan_cut*.csv``), capsized fraction and
    bonds intact at the end against the strength, each seed a marker, the seeds' mean a line."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    tilted = sorted((p.name for p in OUT.glob("scan_cut*.csv") if PLAIN_CUT.fullmatch(p.name)), key=lambda n: float(n[8:-4]))
    names = ["scan.csv", *tilted]
    fig, axes = plt.subplots(2, 1, figsize=(7.5, 7.5), sharex=True, layout="constrained")
    styles = zip(("k", "tab:blue", "tab:red", "tab:green", "tab:purple"), (8, 6, 4, 3, 2), strict=True)
    for name, (colour, size) in zip(names, styles, strict=False):  # smaller markers in front: overlaps stay visible
        rows = read(name)
        if not rows:
            continue
        deg = float(rows[0].get("cut_tilt_deg") or 0)
        label = f"cuts {deg:g}° ± {CUT_STD:g}°" if deg else "vertical cuts"
        strengths = sorted({float(r["strength"]) for r in rows})
        for ax, key in zip(axes, ("capsized", "bonds_intact"), strict=True):
            for seed, marker in zip(sorted({r["seed"] for r in rows}), "os^Dv", strict=False):
                pts = [(float(r["strength"]), float(r[key])) for r in rows if r["seed"] == seed]
                ax.plot(*zip(*pts, strict=True), marker, color=colour, ms=size, mfc="none", label=f"{label}, seed {seed}")
            mean = [np.mean([float(r[key]) for r in rows if float(r["strength"]) == s]) for s in strengths]
            ax.plot(strengths, mean, "-", color=colour, lw=1, alpha=0.7)
        if deg:  # the body v axis past 45 degrees (the model's measure reads a leaning parallelogram as capsized)
            v = [np.mean([float(r["capsized_v"]) for r in rows if float(r["strength"]) == s]) for s in strengths]
            axes[0].plot(strengths, v, "--", color=colour, lw=1, label=f"{label}: v axis past 45° (seeds' mean)")
    n = int(read(names[0])[0]["count"]) if read(names[0]) else 50
    axes[0].axhline(1 / n, color="0.5", lw=0.8, ls=":", label=f"the front alone (1/{n})")
    labels = ("capsized fraction at the end (the model's)", "fraction of bonds intact at the end")
    for ax, label in zip(axes, labels, strict=True):
        ax.set_xscale("log")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3, which="both")
    axes[-1].set_xlabel("tensile strength = shear strength S (rho_w g w); Weibull modulus 5 about it")
    top = axes[0].secondary_xaxis("top", functions=(lambda s: s * PA / 1e3, lambda k: k * 1e3 / PA))
    top.set_xlabel("kPa at w = 70 m")
    axes[1].legend(*axes[0].get_legend_handles_labels(), fontsize=6, ncol=2, loc="center left")
    rows = read(names[0])
    dur = float(rows[0]["duration"]) if rows else float("nan")
    fig.suptitle(f"Shelf to mélange cut by leaning fractures: N = {n}, t = {dur:g}", fontsize=10)
    fig.savefig(OUT / "cuts.png", dpi=120)
    print(f"wrote {OUT / 'cuts.png'}")


PLAIN_CUT = re.compile(r"scan_cut[-0-9.]+\.csv")  # a tilted scan with the rigid law at the scene's resolution


def broke(r: dict, count: int | None = None) -> bool:
    """The shelf broke: more than the front capsized, or under 90% of its bonds intact."""
    n = int(count or float(r["count"]))
    return float(r["capsized"]) > 1.5 / n or (r["bonds_intact"] != "" and float(r["bonds_intact"]) < 0.9)


def critical(rows: list[dict]) -> dict[int, float]:
    """Per seed, the highest strength at which the shelf broke (0: at none of the scan's)."""
    out = {}
    for seed in sorted({int(r["seed"]) for r in rows}):
        hit = [float(r["strength"]) for r in rows if int(r["seed"]) == seed and broke(r)]
        out[seed] = max(hit, default=0.0)
    return out


def laws() -> None:
    """laws.png and laws.csv: the scans with rigid impulses against those with ice crushing at the
    contacts (``--crushing``), at every tilt scanned both ways, and at the other time steps and disc
    counts scanned with crushing: per seed the highest strength at which the shelf broke, and the
    bonds intact at the end against the strength."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = sorted(p.name for p in OUT.glob("scan*_crush*.csv"))
    table, pairs = [], []
    for name in names:
        crushed = read(name)
        deg = float(crushed[0].get("cut_tilt_deg") or 0)
        base = f"scan_cut{deg:g}_crush" if deg else "scan_crush"
        variant = name[len(base) : -len(".csv")].lstrip("_") or "scene's dt and discs"
        laws_here = (("crushing", crushed),)
        if variant == "scene's dt and discs":  # a tilt's rigid scan: listed once, beside its crushing one
            rigid = read(csv_name("scan", deg))
            laws_here = (("rigid", rigid), *laws_here)
            pairs.append((deg, rigid, crushed))
        for law, rows in laws_here:
            for seed, s in critical(rows).items():
                table.append(
                    {"tilt_deg": deg, "law": law, "variant": variant, "seed": seed, "critical": s, "critical_kPa": s * PA / 1e3}
                )
    with open(OUT / "laws.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=("tilt_deg", "law", "variant", "seed", "critical", "critical_kPa"))
        w.writeheader()
        w.writerows(table)
    fig, axes = plt.subplots(1, len(pairs), figsize=(4 * len(pairs), 4), sharey=True, layout="constrained", squeeze=False)
    for ax, (deg, rigid, crushed) in zip(axes[0], sorted(pairs, key=lambda p: p[0]), strict=True):
        for rows, colour, law in ((rigid, "tab:red", "rigid impulses"), (crushed, "tab:blue", "ice crushing")):
            strengths = sorted({float(r["strength"]) for r in rows})
            for seed, marker in zip(sorted({r["seed"] for r in rows}), "os^Dv", strict=False):
                pts = [(float(r["strength"]) * PA / 1e3, float(r["bonds_intact"])) for r in rows if r["seed"] == seed]
                ax.plot(*zip(*pts, strict=True), marker, color=colour, ms=5, mfc="none")
            mean = [np.mean([float(r["bonds_intact"]) for r in rows if float(r["strength"]) == s]) for s in strengths]
            ax.plot([s * PA / 1e3 for s in strengths], mean, "-", color=colour, label=f"{law} (seeds' mean)")
        ax.set_xscale("log")
        ax.set_title(f"cuts {deg:g}° ± {CUT_STD:g}°" if deg else "vertical cuts", fontsize=9)
        ax.set_xlabel("tensile = shear strength (kPa at w = 70 m)")
        ax.grid(alpha=0.3, which="both")
    axes[0][0].set_ylabel("fraction of bonds intact at t = 1000")
    axes[0][0].legend(fontsize=7)
    n = int(pairs[0][1][0]["count"]) if pairs else 50
    fig.suptitle(
        f"An intact shelf of {n} pieces: rigid contact impulses against ice that crushes (seeds as markers)", fontsize=10
    )
    fig.savefig(OUT / "laws.png", dpi=120)
    print(f"wrote {OUT / 'laws.png'}, {OUT / 'laws.csv'}")
    for r in table:
        print(" ".join(f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}" for k, v in r.items()))


def table() -> None:
    """The CSVs' end-state columns again from their run files (where still there)."""
    bases = ("scan", "sweep", "seeds")
    names = [n for base in bases for n in [f"{base}.csv", *sorted(p.name for p in OUT.glob(f"{base}_cut*.csv"))]]
    for name in names:
        rows = read(name)
        for r in rows:
            p = run_path(r["scene"], r["count"], r["strength"], r["seed"], r.get("cut_tilt_deg"))
            if p.exists():
                r |= end_state(p)
        if rows:
            write(rows, name)
            print(f"{name}: {len(rows)} rows")


def floats(text: str) -> list[float]:
    return [float(v) for v in text.split(",")]


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("what", choices=("scan", "sweep", "seeds", "table", "plot", "cuts", "laws"))
    p.add_argument("--count", type=int)
    p.add_argument("--duration", type=float)
    p.add_argument("--strengths", type=floats)
    p.add_argument("--strength", type=float)
    p.add_argument("--seeds", type=lambda t: [int(v) for v in t.split(",")])
    p.add_argument("--no-paper", action="store_true", help="sweep: skip the pre-cut reference runs")
    p.add_argument("--add", action="store_true", help="scan: keep the CSV's rows at other strengths and seeds")
    p.add_argument("--cut-tilt", type=float, default=0.0, help="the cuts' lean in degrees, top seaward > 0 (2.5-degree spread)")
    p.add_argument("--crushing", action="store_true", help="ice crushing at the contacts (effect crushing, its defaults)")
    p.add_argument("--crushing-pressure", type=float, help="with --crushing: physics.crushing_pressure (default 2.0)")
    p.add_argument("--dt", type=float, help="time.dt (default: the scene's 0.01)")
    p.add_argument("--discs", type=int, help="contacts.discs (default: the scene's 28)")
    a = p.parse_args()
    if a.crushing_pressure is not None and not a.crushing:
        sys.exit("--crushing-pressure needs --crushing")
    VARIANT.update(crushing=a.crushing, pressure=a.crushing_pressure, dt=a.dt, discs=a.discs)
    cut = a.cut_tilt
    if a.what == "plot":
        return plot()
    if a.what == "cuts":
        return cuts()
    if a.what == "laws":
        return laws()
    if a.what == "table":
        return table()
    if a.what == "scan":
        n, dur = a.count or 50, a.duration or 1000.0
        if a.crushing and n != 50:
            VARIANT["count"] = n
        strengths = a.strengths or [0.3552, 0.3, 0.25, 0.2, 0.17, 0.15, 0.13, 0.115, 0.1, 0.03, 0.01, 0.003, 0.001, 1e-4]
        rows = [one(SCENE, "shelf_breakup", n, dur, seed, s, cut) for seed in (a.seeds or [1]) for s in strengths]
        if a.add:  # the scan's rows at other strengths or seeds kept, a run done again replaces its row
            done = {(float(r["strength"]), int(r["seed"])) for r in rows}
            kept = [r for r in read(csv_name("scan", cut)) if (float(r["strength"]), int(r["seed"])) not in done]
            rows = sorted(kept + rows, key=lambda r: (int(r["seed"]), -float(r["strength"])))
        write(rows, csv_name("scan", cut))
        return None
    n, dur = a.count or 400, a.duration or 2000.0
    if a.what == "seeds":
        if a.strength is None:
            sys.exit("seeds: --strength is required (a value below the critical strength)")
        rows = [one(SCENE, "shelf_breakup", n, dur, seed, a.strength, cut) for seed in (a.seeds or range(1, 9))]
        write(rows, csv_name("seeds", cut))
        return None
    # rows of the same count and duration already in sweep.csv are kept (a sweep extended in
    # several calls), a run done again replaces its row; the CSV is written after every run
    name = csv_name("sweep", cut)
    rows = [r for r in read(name) if int(r["count"]) == n and float(r["duration"]) == dur]
    seeds = a.seeds or [1, 2]
    todo = [] if a.no_paper else [(PAPER, "paper", seed, None) for seed in seeds]
    todo += [(SCENE, "shelf_breakup", seed, s) for s in a.strengths or [0.3552, 0.2, 0.15, 0.13, 0.1, 0.01] for seed in seeds]
    for path, tag, seed, s in todo:
        row = one(path, tag, n, dur, seed, s, cut)
        key = (tag, str(s if s is not None else ""), str(seed))
        rows = [r for r in rows if (r["scene"], str(r["strength"]), str(r["seed"])) != key] + [row]
        write(sorted(rows, key=lambda r: (r["scene"], float(r["strength"] or 0), int(r["seed"]))), name)
    if not cut:  # phase.png is the vertical cuts' figure
        plot()


if __name__ == "__main__":
    main()

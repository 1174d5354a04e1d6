"""The shelf's critical strength as a weakest-link draw (issue 50, item 4): the peak stress a
capsize puts on each bond of an intact shelf, and the distribution of the strength below which
a bond breaks, against Weibull weakest-link theory, over many seeds.

    python validation/shelf_weakest_link.py --out validation/results/shelf_weakest_link   # ~55 min on one core

``runs/shelf_breakup.toml`` (the paper's icebergs as one bonded shelf, the front one free and
tilted) run once with unbreakable bonds (``tensile_strength = shear_strength = 1e6``; the
Weibull factors drawn as ever) for ``--duration`` time units: every bond's ``bonds/peak_stress``
and ``bonds/peak_shear`` (docs/bonds.md, "Which bond breaks first"), ``p_i`` the larger. A bond's
strength enters nothing but its break check, so a shelf of strength ``S`` (bond ``i`` holding
``S w_i``, ``w_i`` its seed's Weibull factor of modulus ``m`` and mean 1) runs the same until its
first break, and breaks if and only if ``S < S_c = max_i p_i / w_i``. Over the seeds, with the
``w_i`` independent, ``P(S_c < S) = exp(-sum_i (p_i / (lambda S))^m)`` (``lambda = 1 / Gamma(1 +
1/m)``): a Frechet law whose median is ``p_max (n_eff / ln 2)^(1/m) / lambda``, ``n_eff = sum_i
(p_i / p_max)^m`` the number of bonds the stress reaches, weighted as the weakest link weighs
them.

Variants (each a run per seed, ``--seeds`` of them): the scene (N = 50, dt = 0.01, 28 discs), half
the step, twice the discs, N = 100, 200 and 400, and at N = 400 half the step, twice and four
times the discs (``--variants NAME ...`` runs only those named, their rows replacing theirs in
the tables); each with rigid impulses and with ice crushing at the contacts (effect ``crushing``, its
defaults). The seed draws the front's tilt as well as the strengths, so each seed's peaks are its
own run's, and a variant's theory is the mean over its seeds of each seed's law. For the scene,
``--check`` seeds (and at N = 400 ``--check-long``) are run again by the model a hair either side
of their ``S_c`` (``1 +- 1e-6``): no bond breaks above, the predicted bond breaks first below;
beside it, whether that first break took the shelf apart (more than the front capsized, or
under 90% of the bonds intact: ``shelf_breakup.py``'s measure). Writes
``peaks.csv.gz`` (every bond of every variant and seed), ``laws.csv`` (each variant's theory), ``seeds.csv``
(per seed: ``S_c`` from the draws, the model's check), ``weakest_link.png`` and the printed lines
in ``weakest_link.log``, the last the unbreakable runs' energy budgets (``--budgets``: that line
alone, from the run files of ``--duration`` left in ``runs/shelf_weakest_link/``). ``--plot``
draws the figure again from the tables in ``--out``.
"""

from __future__ import annotations

import argparse
import csv
import gzip
import math
import sys
import time
from pathlib import Path

import h5py
import numpy as np

import melange_ti as mt
from melange_ti.physics.effects import REGISTRY
from melange_ti.physics.effects.bonds import Bond, host, pascals, weibull_scale

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "runs" / "shelf_breakup.toml"
RUNS = ROOT / "runs" / "shelf_weakest_link"
KPA = pascals(70.0) / 1e3  # the stress unit at w = 70 m, in kPa
BIG = 1e6
# (name, count, dt, discs)
VARIANTS = (
    ("scene", 50, None, None),
    ("dt / 2", 50, 0.005, None),
    ("56 discs", 50, None, 56),
    ("N = 100", 100, None, None),
    ("N = 200", 200, None, None),
    ("N = 400", 400, None, None),
    ("N = 400, dt / 2", 400, 0.005, None),
    ("N = 400, 56 discs", 400, None, 56),
    ("N = 400, 112 discs", 400, None, 112),
)
LAWS = ("rigid", "crushing")
DURATION = 1000.0  # --duration's default: its runs' file names carry no duration
QUANTILES = (0.05, 0.5, 0.95)


def log(text: str, fh) -> None:
    print(text, flush=True)
    fh.write(text + "\n")


def overrides(law: str, count: int, dt, discs, duration: float, seed: int, strength: float) -> dict:
    over = {
        "shelf.count": count,
        "time.duration": duration,
        "time.seed": seed,
        "physics.tensile_strength": strength,
        "physics.shear_strength": strength,
        "output.snapshot_interval": duration / 10,
    }
    if law == "crushing":
        named = mt.load_scene(SCENE).effects
        over["scene.effects"] = [e.name for e in REGISTRY if getattr(named, e.name)] + ["crushing"]
    if dt is not None:
        over["time.dt"] = dt
    if discs is not None:
        over["contacts.discs"] = discs
    return over


def lasting(duration: float) -> str:
    """The end of a run file's name that says its duration (none for DURATION)."""
    return "" if duration == DURATION else f"_t{duration:g}".replace(".", "p")


def run(over: dict, name: str) -> Path:
    RUNS.mkdir(parents=True, exist_ok=True)
    out = RUNS / f"{name}.h5"
    mt.run(mt.load_scene(SCENE, overrides=over), out=out, overwrite=True, threads=1)
    return out


def peaks(law: str, count: int, dt, discs, duration: float, seed: int) -> dict:
    """The unbreakable shelf's bonds: peak ``p``, where (``depth``: the bond's distance from the
    shelf's seaward face at t = 0, in widths; the wall's bond at the shelf's length), and kind."""
    tag = f"{law}_{count}_{dt or 'dt'}_{discs or 'discs'}_{seed}".replace(".", "p") + lasting(duration)
    out = run(overrides(law, count, dt, discs, duration, seed, BIG), tag)
    with h5py.File(out, "r") as f:
        g = f["bonds"]
        a, b = g["a"][:], g["b"][:]
        sig, tau = g["peak_stress"][:], g["peak_shear"][:]
        intact = np.isnan(g["break_time"][:])
        x0 = f["snapshots/x"][0]
        th0 = f["snapshots/theta"][0]
        width = f["icebergs/width"][:]
    assert intact.all(), "the unbreakable shelf broke"
    shelf = np.unique(np.concatenate([a, b[b >= 0]]))  # the bonded icebergs: the front is free
    face = float(np.max(x0[shelf] + width[shelf] / 2))
    xb = np.where(b >= 0, (x0[a] + x0[np.maximum(b, 0)]) / 2, 0.0)
    front = int(np.argmax(x0))
    p = np.maximum(sig, tau)
    return {"a": a, "b": b, "sig": sig, "tau": tau, "p": p, "depth": face - xb, "front_tilt": float(th0[front])}


def factors(count: int, seed: int) -> np.ndarray:
    """The seed's Weibull factors ``w_i`` in bond order, as the scene draws them (mean 1: the scene
    has no ``strength_size`` or joint strength, whose fixed factors the law would need apart)."""
    sc = mt.load_scene(SCENE, overrides={"shelf.count": count, "time.seed": seed, "physics.tensile_strength": BIG})
    bergs = sc.icebergs()
    pairs, _ = host.pairs(sc, bergs)
    table = host.build(sc, bergs, pairs)
    on = table[:, Bond.A] >= 0
    return table[on, Bond.ST] / BIG


def law_of(p: np.ndarray, m: float) -> dict:
    lam = weibull_scale(m)
    total = float(np.sum(p**m))
    q = {f"q{int(100 * x)}": (total / -math.log(x)) ** (1 / m) / lam for x in QUANTILES}
    return {"p_max": float(p.max()), "n_eff": total / float(p.max()) ** m, **q}


def deep_share(p: np.ndarray, depth: np.ndarray, m: float, beyond: float = 20.0) -> float:
    """The share of the weakest link's weight ``sum_i p_i^m`` carried by bonds deeper than ``beyond`` w."""
    return float(np.sum(p[depth > beyond] ** m) / np.sum(p**m))


def cdf(s: np.ndarray, p: np.ndarray, m: float) -> np.ndarray:
    return np.exp(-np.sum((p[None, :] / (weibull_scale(m) * s[:, None])) ** m, axis=1))


def broke(out: Path) -> tuple[int, bool]:
    """Bonds broken, and whether the shelf broke up (``shelf_breakup.py``'s measure)."""
    from melange_ti.diagnostics import capsized

    with h5py.File(out, "r") as f:
        n_broken = int(np.sum(~np.isnan(f["bonds/break_time"][:])))
        n_bonds = f["bonds/a"].shape[0]
        caps = capsized(f["snapshots/theta"][:])[-1]
    return n_broken, bool(caps.sum() > 1.5 or n_broken > 0.1 * n_bonds)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--out", type=Path, default=ROOT / "validation" / "results" / "shelf_weakest_link")
    p.add_argument("--duration", type=float, default=DURATION)
    p.add_argument("--seeds", type=int, default=16, help="seeds: each an unbreakable run of every variant")
    p.add_argument("--check", type=int, default=16, help="seeds the model runs again either side of S_c (the scene)")
    p.add_argument("--check-long", type=int, default=4, help="seeds the model runs again either side of S_c (N = 400)")
    p.add_argument(
        "--budgets", action="store_true", help="only the budgets of the runs of --duration left in runs/shelf_weakest_link/"
    )
    p.add_argument("--plot", action="store_true", help="only the figure, drawn again from the tables in --out")
    p.add_argument("--variants", nargs="+", choices=[v[0] for v in VARIANTS], metavar="NAME",
                   help="run only these variants, their rows replacing theirs in the tables in --out")  # fmt: skip
    a = p.parse_args()
    a.out.mkdir(parents=True, exist_ok=True)
    if a.budgets:
        with open(a.out / "weakest_link.log", "a") as fh:
            return budgets(fh, a.duration)
    m = mt.load_scene(SCENE).physics.strength_modulus
    grid = np.geomspace(5, 2000, 4000) / KPA
    if a.plot:
        found, seed_rows = tables(a.out)
        return plot(a.out, found, seed_rows, grid, m)
    chosen = set(a.variants or [v[0] for v in VARIANTS])
    fh = open(a.out / "weakest_link.log", "a" if a.variants else "w")
    log(f"# {' '.join(sys.argv)}; Weibull modulus {m}; strengths in kPa at w = 70 m", fh)
    law_rows, peak_rows, seed_rows = [], [], []
    for law in LAWS:
        for name, count, dt, discs in VARIANTS:
            if name not in chosen:
                continue
            t0 = time.time()
            per = []
            for seed in range(1, a.seeds + 1):
                got = peaks(law, count, dt, discs, a.duration, seed)
                w = factors(count, seed)
                assert w.size == got["p"].size
                ratio = got["p"] / w
                k, top = int(np.argmax(ratio)), int(np.argmax(got["p"]))
                th = law_of(got["p"], m)
                got.update(seed=seed, w=w, s_c=float(ratio[k]), first=k)
                per.append(got)
                seed_rows.append(
                    {"law": law, "variant": name, "count": count, "seed": seed, "front_tilt": got["front_tilt"],
                     "p_max_kPa": th["p_max"] * KPA, "p_max_depth": float(got["depth"][top]), "n_eff": th["n_eff"],
                     "median_kPa": th["q50"] * KPA, "S_c": float(ratio[k]), "S_c_kPa": float(ratio[k]) * KPA, "bond": k,
                     "depth": float(got["depth"][k]), "w": float(w[k])}
                )  # fmt: skip
                for i in range(got["p"].size):
                    sig, tau = f"{got['sig'][i]:.6g}", f"{got['tau'][i]:.6g}"
                    peak_rows.append(
                        {"law": law, "variant": name, "seed": seed, "bond": i, "a": int(got["a"][i]), "b": int(got["b"][i]),
                         "depth": float(got["depth"][i]), "peak_stress": sig, "peak_shear": tau}
                    )  # fmt: skip
            mix = np.mean([cdf(grid, g["p"], m) for g in per], axis=0)  # over the seeds' trajectories
            q = {f"q{int(100 * x)}_kPa": float(np.interp(x, mix, grid)) * KPA for x in QUANTILES}
            sc = np.sort([g["s_c"] for g in per])
            gap = float(np.max(np.abs(np.arange(1, sc.size + 1) / sc.size - np.interp(sc, grid, mix))))
            pm = np.array([g["p"].max() for g in per]) * KPA
            # the wall's bond sits the shelf's length from its face (this scene: width 1, front = 1, wall_x = 0)
            wall = np.mean([g["depth"][int(np.argmax(g["p"]))] >= count - 1.5 for g in per])
            row = {"law": law, "variant": name, "count": count, "seeds": len(per), "p_max_kPa_mean": pm.mean(),
                   "p_max_kPa_min": pm.min(), "p_max_kPa_max": pm.max(), "p_max_at_wall": wall,
                   "n_eff_mean": float(np.mean([law_of(g["p"], m)["n_eff"] for g in per])), **q,
                   "S_c_kPa_median": float(np.median(sc)) * KPA, "S_c_kPa_min": sc[0] * KPA, "S_c_kPa_max": sc[-1] * KPA,
                   "gap_to_theory": gap, "deep_share": float(np.mean([deep_share(g["p"], g["depth"], m) for g in per])),
                   "p_max_depths": " ".join(f"{v:g}" for v in sorted({g["depth"][np.argmax(g["p"])] for g in per}))}  # fmt: skip
            law_rows.append(row)
            log(
                f"{law:8s} {name:9s} p_max {pm.mean():6.1f} kPa ({pm.min():.1f}-{pm.max():.1f}; at the wall in {wall:.0%}), "
                f"n_eff {row['n_eff_mean']:5.2f}; theory S_c 5/50/95% {q['q5_kPa']:6.1f} {q['q50_kPa']:6.1f} "
                f"{q['q95_kPa']:6.1f}; seeds' S_c median {row['S_c_kPa_median']:6.1f} ({row['S_c_kPa_min']:.1f}-"
                f"{row['S_c_kPa_max']:.1f}), largest gap to the theory's CDF {gap:.3f} ({time.time() - t0:.0f} s)",
                fh,
            )
            write(a.out / "laws.csv", merged(a.out / "laws.csv", law_rows, chosen) if a.variants else law_rows)
    write(a.out / "peaks.csv.gz", merged(a.out / "peaks.csv.gz", peak_rows, chosen) if a.variants else peak_rows)

    # the model's check of the first break, a hair either side of each seed's S_c (the scene)
    for row in seed_rows:
        if not (
            (row["variant"] == "scene" and row["seed"] <= a.check)
            or (row["variant"] == "N = 400" and row["seed"] <= a.check_long)
        ):
            continue
        s_c, seed, law, n = row["S_c"], row["seed"], row["law"], row["count"]
        above = run(overrides(law, n, None, None, a.duration, seed, s_c * (1 + 1e-6)), "check_above")
        below = run(overrides(law, n, None, None, a.duration, seed, s_c * (1 - 1e-6)), "check_below")
        n_above, _ = broke(above)
        n_below, apart = broke(below)
        with h5py.File(below, "r") as f:
            bt = f["bonds/break_time"][:]
        first = np.flatnonzero(bt == np.nanmin(bt)).tolist() if n_below else []
        row.update(broken_above=n_above, broken_below=n_below, first_below=" ".join(map(str, first)), apart_below=apart)
        log(
            f"{law:8s} N = {n} seed {seed:3d} (front tilt {row['front_tilt']:+.4f}): S_c {row['S_c_kPa']:6.1f} kPa, bond "
            f"{row['bond']} ({row['depth']:.1f} w in, w = {row['w']:.3f}); above: {n_above} broken; below: {n_below} "
            f"broken, first {first}, {'apart' if apart else 'holds'}",
            fh,
        )
    write(a.out / "seeds.csv", merged(a.out / "seeds.csv", seed_rows, chosen) if a.variants else seed_rows)
    plot(a.out, *tables(a.out), grid, m)
    budgets(fh, a.duration)
    fh.close()


def budgets(fh, duration: float) -> None:
    """The energy budget of every unbreakable run of ``duration`` left in
    ``runs/shelf_weakest_link/``: its largest residual over the run relative to the largest
    released energy."""
    from melange_ti.analysis import stats

    worst = []
    for path in sorted(RUNS.glob("*.h5")):
        tail = lasting(duration)
        if path.name.startswith("check_") or ("_t" in path.stem) != bool(tail) or not path.stem.endswith(tail):
            continue
        with h5py.File(path, "r") as f:
            budget = stats.energy_budget({k: f["diagnostics"][k][:] for k in f["diagnostics"]})
        rel = np.max(np.abs(budget["residual"])) / max(float(np.max(np.abs(budget["released"]))), 1e-30)
        worst.append((float(rel), path.name))
    if worst:
        rels = [w for w, _ in worst]
        log(f"budget: {len(worst)} runs, largest |residual| / released over each run: median {np.median(rels):.2g}, "
            f"largest {max(worst)[0]:.2g} ({max(worst)[1]})", fh)  # fmt: skip


def write(path: Path, rows: list[dict]) -> None:
    """``rows`` as CSV (gzipped when ``path`` ends in ``.gz``; mtime 0: the same rows, the same bytes)."""
    import io

    keys = list(dict.fromkeys(k for r in rows for k in r))
    if path.suffix == ".gz":
        text = io.StringIO(newline="")
        w = csv.DictWriter(text, keys)
        w.writeheader()
        w.writerows(rows)
        path.write_bytes(gzip.compress(text.getvalue().encode(), mtime=0))
        return
    with open(path, "w", newline="") as fh:
        w = csv.DictWriter(fh, keys)
        w.writeheader()
        w.writerows(rows)


def merged(path: Path, rows: list[dict], chosen: set) -> list[dict]:
    """The rows of the table at ``path`` (for ``--variants``): ``rows`` for each (law,
    variant) they hold, the table's own for every other (so a run stopped half-way loses
    nothing), in the order of LAWS and VARIANTS. ``chosen``: the variants named."""
    done = {(r["law"], r["variant"]) for r in rows}
    assert {v for _, v in done} <= chosen
    kept = []
    if path.exists():
        with (gzip.open if path.suffix == ".gz" else open)(path, "rt") as fh:
            kept = [r for r in csv.DictReader(fh) if (r["law"], r["variant"]) not in done]
    order = {(law, v[0]): k for k, (law, v) in enumerate((law, v) for law in LAWS for v in VARIANTS)}
    return sorted(kept + rows, key=lambda r: order[(r["law"], r["variant"])])  # stable: the seeds' order kept


def tables(out: Path) -> tuple[dict, list[dict]]:
    """The peaks and the seeds' rows as ``main`` holds them, read back from ``peaks.csv.gz``
    and ``seeds.csv`` (for ``--plot``)."""
    with gzip.open(out / "peaks.csv.gz", "rt") as fh:
        peaks_rows = list(csv.DictReader(fh))
    found = {}
    for law in LAWS:
        for name, *_ in VARIANTS:
            rows = [r for r in peaks_rows if r["law"] == law and r["variant"] == name]
            for seed in sorted({int(r["seed"]) for r in rows}):
                mine = [r for r in rows if int(r["seed"]) == seed]
                p = np.maximum([float(r["peak_stress"]) for r in mine], [float(r["peak_shear"]) for r in mine])
                found.setdefault((law, name), []).append({"p": p, "depth": np.array([float(r["depth"]) for r in mine])})
    seed_rows = []
    with open(out / "seeds.csv") as fh:
        seed_file = list(csv.DictReader(fh))
    for r in seed_file:
        row = {**r, "S_c": float(r["S_c"]), "S_c_kPa": float(r["S_c_kPa"]), "seed": int(r["seed"]), "bond": int(r["bond"])}
        if r.get("broken_below"):
            row.update(broken_above=int(r["broken_above"]), broken_below=int(r["broken_below"]))
        else:
            for key in ("broken_above", "broken_below", "first_below", "apart_below"):
                row.pop(key, None)
        seed_rows.append(row)
    return found, seed_rows


def plot(out: Path, found: dict, seed_rows: list[dict], grid: np.ndarray, m: float) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 2, figsize=(12, 8.5), constrained_layout=True)
    for col, law in enumerate(LAWS):
        ax = axes[0, col]
        for name, colour in (("scene", "C0"), ("N = 400", "C3")):
            for k, g in enumerate(found.get((law, name), [])):
                order = np.argsort(g["depth"])
                ax.semilogy(g["depth"][order], g["p"][order] * KPA, "-", color=colour, lw=0.6, alpha=0.6,
                            label=f"{name}, {len(found[(law, name)])} seeds" if k == 0 else None)  # fmt: skip
        ax.set(xlabel="bond's distance from the shelf's face (w)", ylabel="peak stress (kPa)", xscale="symlog",
               ylim=(8, 300), title=f"{law}: each bond's peak stress (unbreakable shelf)")  # fmt: skip
        ax.legend(fontsize=7)
        ax = axes[1, col]
        for name, *_ in VARIANTS:
            if (law, name) not in found:
                continue
            mix = np.mean([cdf(grid, g["p"], m) for g in found[(law, name)]], axis=0)
            ax.plot(grid * KPA, mix, lw=1, label=f"theory, {name}")
        got = np.sort([r["S_c"] for r in seed_rows if r["law"] == law and r["variant"] == "scene"])
        if got.size:
            frac = np.arange(1, got.size + 1) / got.size
            ax.step(got * KPA, frac, "k", where="post", lw=1.5, label=f"the scene's {got.size} seeds")
        checked = [r for r in seed_rows if r["law"] == law and r["variant"] == "scene" and "broken_below" in r]
        ok = [r for r in checked if r["broken_above"] == 0 and r["first_below"] == str(r["bond"])]
        if checked:
            label = f"the model's check ({len(ok)} of {len(checked)})"
            ax.plot([r["S_c_kPa"] for r in ok], [0.03] * len(ok), "r|", ms=12, label=label)
        ax.set(xlabel="strength S (kPa)", ylabel="P(S_c < S): no bond breaks", xscale="log", xlim=(30, 600),
               title=f"{law}: the strength below which a bond breaks")  # fmt: skip
        ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
        ax.set_xticks([30, 50, 100, 200, 400], ["30", "50", "100", "200", "400"])
        ax.legend(fontsize=7)
    fig.savefig(out / "weakest_link.png", dpi=130)


if __name__ == "__main__":
    main()

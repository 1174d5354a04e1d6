"""Irregular fragments in the paper's scene (issue #33): a shelf cut by tilted fracture faces.

    python validation/shelf_cuts.py [--out runs/shelf_cuts] [--workers 2] [--seeds 1,...,8]
    python validation/shelf_cuts.py --no-run      # the CSV, figure and log again from the run files

The paper's scene (the bundled one: 400 icebergs 1 x 1.4, gap 0.1) to ``time.duration = 1000``
for seeds 1-8, in six groups: ``regular`` (the paper's rectangles), ``width``
(``shelf.width_std = 0.1``, vertical cuts) and ``tilt5``, ``tilt10``, ``tilt20``, ``tilt20in``:
the width spread and every fracture leaning alike by ``shelf.cut_tilt`` = 5, 10, 20 and -20
degrees (positive: the cut's top seaward; ``tilt20in`` leans landward) with a 2.5-degree spread
(``shelf.cut_tilt_std = 0.0436``), so the icebergs are quadrilaterals (docs/model.md, Outlines).
Each run is its own ``python -m melange_ti run`` process on one thread (``--workers`` side by
side), run from this checkout; a run file that exists and is complete is kept, a refused seed
(exit status 2) is recorded and not run again (``NAME.json`` next to each run file holds its
exit status, message and wall time), so the script resumes where it stopped.

Writes, in ``validation/results/``: ``shelf_cuts.csv`` (per run: the capsized fraction and the
leading edge at t = 250, 500, 1000, the capsized fraction by the body's v axis instead of the
outline's principal axis, the capsize angle at t = 0 and the upright icebergs' mean tilt; per
group: mean, s.d. and standard error over the seeds in rows ``seed = mean, sd, se``, and
Welch's t against ``regular`` at t = 1000 in rows ``seed = welch_MEASURE_1000_vs_regular``, which
hold the difference of the means in that measure's t = 1000 column), ``shelf_cuts.png`` (both
measures against time, seed mean +- 1 standard error) and
``shelf_cuts.log`` (the command line, each run's wall time, the findings).
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import h5py
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from scipy import stats as sps  # noqa: E402

import melange_ti as mt  # noqa: E402
from melange_ti.diagnostics import capsize_angle  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "validation" / "results"
DURATION = 1000.0
TIMES = (250.0, 500.0, 1000.0)
SPREAD = {"shelf.width_std": 0.1, "shelf.cut_tilt_std": 0.0436}
GROUPS = {  # name -> (mean cut tilt in degrees or None for vertical cuts, --set overrides)
    "regular": (None, {}),
    "width": (0.0, {"shelf.width_std": 0.1}),
    "tilt5": (5.0, {"shelf.cut_tilt": 0.0873, **SPREAD}),
    "tilt10": (10.0, {"shelf.cut_tilt": 0.1745, **SPREAD}),
    "tilt20": (20.0, {"shelf.cut_tilt": 0.3491, **SPREAD}),
    "tilt20in": (-20.0, {"shelf.cut_tilt": -0.3491, **SPREAD}),
}
MEASURES = ("capsized", "leading_edge", "capsized_v")


def label(group: str) -> str:
    tilt, _ = GROUPS[group]
    if tilt is None:
        return f"{group}: paper, rectangles 1 x 1.4"
    if tilt == 0:
        return f"{group}: vertical cuts, width s.d. 0.1"
    return f"{group}: cuts {tilt:+g}° ± 2.5° ({'seaward' if tilt > 0 else 'landward'}), width s.d. 0.1"


def run_file(out: Path, group: str, seed: int) -> Path:
    return out / f"{group}_seed{seed}.h5"


def complete(path: Path) -> bool:
    try:
        with h5py.File(path, "r") as f:
            return bool(f.attrs.get("complete", False))
    except OSError:
        return False


def one(out: Path, group: str, seed: int) -> dict:
    """Run one seed of one group in its own process (unless done or refused before)."""
    path = run_file(out, group, seed)
    meta = path.with_suffix(".json")
    if meta.exists():
        rec = json.loads(meta.read_text())
        if rec["rc"] == 2 or (rec["rc"] == 0 and complete(path)):
            return rec | {"skipped": True}
    sets = {"time.duration": DURATION, "time.seed": seed, **GROUPS[group][1]}
    cmd = [sys.executable, "-m", "melange_ti", "run", "--out", str(path), "--overwrite", "--threads", "1"]
    for k, v in sets.items():
        cmd += ["--set", f"{k}={v}"]
    env = os.environ | {"PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]).rstrip(os.pathsep)}
    t0 = time.time()
    p = subprocess.run(cmd, capture_output=True, text=True, env=env, cwd=ROOT)
    rec = {
        "group": group,
        "seed": seed,
        "rc": p.returncode,
        "wall_s": round(time.time() - t0, 1),
        "cmd": " ".join(cmd[1:]),
        "stdout": p.stdout.strip().splitlines()[:1],
        "message": p.stderr.strip().splitlines()[-1] if p.stderr.strip() else "",
    }
    meta.write_text(json.dumps(rec, indent=1))
    status = "ok" if p.returncode == 0 else f"exit {p.returncode}: {rec['message']}"
    print(f"{group} seed {seed}: {rec['wall_s']} s, {status}", flush=True)
    return rec | {"skipped": False}


def read(path: Path) -> dict:
    """Curves and the per-run numbers of one run file."""
    with mt.open_run(path) as tree:
        d = tree["diagnostics"]
        t = d["time"].values
        caps, edge = d["capsized_fraction"].values, d["leading_edge"].values
        s = tree["snapshots"]
        ts, theta = s["time"].values, s["theta"].values
        ice = tree["icebergs"]
        axis = ice["axis"].values if "axis" in ice else np.zeros(theta.shape[1])
    phi0 = np.degrees(capsize_angle(theta[0], axis))
    row = {
        "capsized_0": float(caps[0]),
        "phi0_mean_deg": float(phi0.mean()),
        "phi0_min_deg": float(phi0.min()),
        "phi0_max_deg": float(phi0.max()),
        "axis_mean_deg": float(np.degrees(axis.mean())),
    }
    capv = (capsize_angle(theta) >= np.pi / 4).mean(axis=1)  # by the body's v axis, at the snapshots
    for tt in TIMES:
        i, j = int(np.argmin(np.abs(t - tt))), int(np.argmin(np.abs(ts - tt)))
        row[f"capsized_{tt:g}"] = float(caps[i])
        row[f"leading_edge_{tt:g}"] = float(edge[i])
        row[f"capsized_v_{tt:g}"] = float(capv[j])
    row["capsized_10"] = float(caps[int(np.argmin(np.abs(t - 10.0)))])
    wrapped = np.mod(theta[-1] + np.pi / 2, np.pi) - np.pi / 2  # tilt of the v axis, in [-90, 90) degrees
    upright = np.abs(wrapped) < np.pi / 4
    lean = np.abs(np.degrees(wrapped))
    row["v_within_10"], row["v_lean_10_45"] = float(np.mean(lean < 10)), float(np.mean((lean >= 10) & (lean < 45)))
    row["upright_tilt_deg_1000"] = float(np.degrees(wrapped[upright].mean())) if upright.any() else float("nan")
    return {"row": row, "t": t, "capsized": caps, "leading_edge": edge, "ts": ts, "capsized_v": capv}


def welch(a: np.ndarray, b: np.ndarray) -> tuple[float, float, float]:
    """Welch's t of mean(a) - mean(b), its degrees of freedom and two-sided p."""
    r = sps.ttest_ind(a, b, equal_var=False)
    va, vb = a.var(ddof=1) / a.size, b.var(ddof=1) / b.size
    dof = (va + vb) ** 2 / (va**2 / (a.size - 1) + vb**2 / (b.size - 1)) if va + vb > 0 else float("nan")
    return float(r.statistic), float(dof), float(r.pvalue)


def fmt(v) -> str:
    return f"{v:.6g}" if isinstance(v, float) else str(v)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", type=Path, default=ROOT / "runs" / "shelf_cuts", help="directory of the run files")
    p.add_argument("--workers", type=int, default=2, help="runs side by side, one thread each")
    p.add_argument("--seeds", type=lambda s: [int(v) for v in s.split(",")], default=list(range(1, 9)))
    p.add_argument("--groups", type=lambda s: s.split(","), default=list(GROUPS))
    p.add_argument("--no-run", action="store_true", help="only read the run files there")
    a = p.parse_args()
    a.out.mkdir(parents=True, exist_ok=True)
    RESULTS.mkdir(parents=True, exist_ok=True)
    jobs = [(g, s) for g in a.groups for s in a.seeds]
    t_start = time.time()
    if not a.no_run:
        print(f"{len(jobs)} runs into {a.out}, {a.workers} at a time; melange_ti from {Path(mt.__file__).parent}", flush=True)
        with ThreadPoolExecutor(a.workers) as pool:
            list(pool.map(lambda job: one(a.out, *job), jobs))
    sessions_file = a.out / "sessions.json"
    sessions = json.loads(sessions_file.read_text()) if sessions_file.exists() else []
    if not a.no_run:
        sessions.append({"command": " ".join([Path(sys.executable).name, *sys.argv]), "wall_s": round(time.time() - t_start)})
        sessions_file.write_text(json.dumps(sessions, indent=1))

    # per run
    rows, curves, recs = [], {}, {}
    for g, s in jobs:
        meta = run_file(a.out, g, s).with_suffix(".json")
        rec = json.loads(meta.read_text()) if meta.exists() else {"rc": None, "wall_s": float("nan"), "message": "not run"}
        recs[g, s] = rec
        path = run_file(a.out, g, s)
        base = {"group": g, "cut_tilt_deg": "vertical" if GROUPS[g][0] is None else GROUPS[g][0], "seed": s}
        if rec["rc"] == 0 and complete(path):
            r = read(path)
            curves[g, s] = r
            rows.append(base | {"status": "ok", "wall_s": rec["wall_s"]} | r["row"])
        else:
            rows.append(base | {"status": f"refused: {rec['message']}" if rec["rc"] == 2 else f"missing (exit {rec['rc']})"})
    cols = ["group", "cut_tilt_deg", "seed", "status", "n"]
    cols += [f"{m}_{tt:g}" for m in MEASURES for tt in TIMES]
    cols += ["welch_t", "welch_dof", "welch_p", "capsized_0", "phi0_mean_deg", "phi0_min_deg", "phi0_max_deg"]
    cols += ["axis_mean_deg", "upright_tilt_deg_1000", "wall_s"]

    # per group: mean, s.d., standard error; Welch's t against regular at t = 1000
    summary = []
    keys = [f"{m}_{tt:g}" for m in MEASURES for tt in TIMES]
    keys += ["phi0_mean_deg", "phi0_min_deg", "phi0_max_deg", "capsized_0", "capsized_10"]
    keys += ["upright_tilt_deg_1000", "v_within_10", "v_lean_10_45"]
    values = {g: {k: np.array([r[k] for r in rows if r["group"] == g and r["status"] == "ok"]) for k in keys} for g in a.groups}
    for g in a.groups:
        v = values[g]
        n = v["capsized_1000"].size
        for stat in ("mean", "sd", "se"):
            row = {"group": g, "cut_tilt_deg": rows[[r["group"] for r in rows].index(g)]["cut_tilt_deg"], "seed": stat, "n": n}
            for k, x in v.items():
                if x.size:
                    sd = float(x.std(ddof=1)) if x.size > 1 else float("nan")
                    row[k] = float(x.mean()) if stat == "mean" else sd if stat == "sd" else sd / np.sqrt(x.size)
            summary.append(row)
        if g != "regular" and "regular" in values and n > 1:
            for m in MEASURES:
                tw, dof, pw = welch(v[f"{m}_1000"], values["regular"][f"{m}_1000"])
                diff = float(v[f"{m}_1000"].mean() - values["regular"][f"{m}_1000"].mean())
                summary.append(
                    {"group": g, "cut_tilt_deg": "", "seed": f"welch_{m}_1000_vs_regular", "n": n}
                    | {"welch_t": tw, "welch_dof": dof, "welch_p": pw, f"{m}_1000": diff}
                )
    with open(RESULTS / "shelf_cuts.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=cols, extrasaction="ignore")
        w.writeheader()
        for r in rows + summary:
            w.writerow({k: fmt(r[k]) for k in cols if k in r})

    # figure: seed mean +- 1 standard error against time
    fig, axes = plt.subplots(2, 1, figsize=(8, 8), sharex=True, layout="constrained")
    colours = dict(zip(GROUPS, ("k", "tab:grey", "tab:blue", "tab:green", "tab:red", "tab:purple"), strict=True))
    for g in a.groups:
        runs = [curves[g, s] for s in a.seeds if (g, s) in curves]
        if not runs:
            continue
        t = runs[0]["t"]
        for ax, key in zip(axes, ("capsized", "leading_edge"), strict=True):
            y = np.array([np.interp(t, r["t"], r[key]) for r in runs])
            m, se = y.mean(0), y.std(0, ddof=1) / np.sqrt(len(runs)) if len(runs) > 1 else 0 * y[0]
            ax.plot(t, m, color=colours[g], lw=1.4, label=f"{label(g)} (n = {len(runs)})" if key == "leading_edge" else None)
            ax.fill_between(t, m - se, m + se, color=colours[g], alpha=0.2, lw=0)
        if GROUPS[g][0] not in (None, 0.0):
            ts = runs[0]["ts"]
            yv = np.array([np.interp(ts, r["ts"], r["capsized_v"]) for r in runs]).mean(0)
            axes[0].plot(ts, yv, color=colours[g], lw=1.0, ls="--")
    axes[0].plot([], [], "k-", lw=1.4, label="capsized (the model's: principal axis nearest v past 45°)")
    axes[0].plot([], [], "k--", lw=1.0, label="tilted cuts: the body's v axis past 45° (snapshots, every 10)")
    axes[0].set_ylabel("capsized fraction")
    axes[1].set_ylabel("leading edge (widths)")
    axes[1].set_xlabel("time (sqrt(w/g))")
    axes[0].set_title("paper scene, 400 icebergs, 8 seeds: seed mean ± 1 standard error", fontsize=10)
    axes[0].legend(fontsize=7.5, loc="center right", bbox_to_anchor=(1.0, 0.62))
    axes[1].legend(fontsize=7.5, loc="lower right")
    for ax in axes:
        ax.grid(alpha=0.3)
        ax.set_xlim(0, DURATION)
    fig.savefig(RESULTS / "shelf_cuts.png", dpi=130)

    # log
    lines = [
        "command: " + " ".join([Path(sys.executable).name, *sys.argv]),
        f"melange_ti: {Path(mt.__file__).parent}, run files in {a.out}",
        *[f"run session: {x['command']}: {x['wall_s']} s wall ({x['wall_s'] / 60:.1f} min)" for x in sessions],
        "",
        f"runs (wall s per run, one thread each, up to {a.workers} side by side; a kept run shows the wall time of the"
        " invocation that made it):",
    ]
    total = 0.0
    for (g, s), rec in recs.items():
        total += rec["wall_s"] if rec.get("wall_s") == rec.get("wall_s") else 0.0
        msg = "ok" if rec["rc"] == 0 else f"exit {rec['rc']}: {rec.get('message', '')}"
        lines.append(f"  {g:9s} seed {s}: {rec.get('wall_s', float('nan')):7.1f} s  {msg}  {' '.join(rec.get('stdout', []))}")
    lines.append(f"sum of the runs' wall times: {total:.0f} s ({total / 60:.1f} min)")
    lines += ["", "t = 1000, mean ± standard error over the seeds (s.d. in the CSV):"]
    for g in a.groups:
        v = values[g]
        if v["capsized_1000"].size:
            n = v["capsized_1000"].size
            se = lambda x: x.std(ddof=1) / np.sqrt(x.size) if x.size > 1 else float("nan")  # noqa: E731
            lines.append(
                f"  {g:9s} n = {n}: capsized {v['capsized_1000'].mean():.4f} ± {se(v['capsized_1000']):.4f}, "
                f"by v axis {v['capsized_v_1000'].mean():.4f} ± {se(v['capsized_v_1000']):.4f}, "
                f"leading edge {v['leading_edge_1000'].mean():.2f} ± {se(v['leading_edge_1000']):.2f}"
            )
    lines += ["", "Welch's t against regular at t = 1000 (difference of means, t, dof, two-sided p):"]
    for r in summary:
        if str(r["seed"]).startswith("welch"):
            m = r["seed"][len("welch_") : -len("_1000_vs_regular")]
            lines.append(
                f"  {r['group']:9s} {m:13s} diff {r[f'{m}_1000']:+.4f}  t = {r['welch_t']:+.2f}"
                f"  dof = {r['welch_dof']:.1f}  p = {r['welch_p']:.2g}"
            )
    lines += ["", "per group (seed means): capsized at t = 0 and t = 10; phi at t = 0 (deg): mean, min and max over runs;"]
    lines += ["  the v axis' tilt at t = 1000: share within 10° of upright, leaning 10-45°, past 45° (rolled onto a side):"]
    for g in a.groups:
        v = values[g]
        if v["capsized_1000"].size:
            lines.append(
                f"  {g:9s} capsized(0) {v['capsized_0'].mean():.5f} (runs with one: {int(np.sum(v['capsized_0'] > 0))}),"
                f" capsized(10) {v['capsized_10'].mean():.3f};"
                f" phi0 {v['phi0_mean_deg'].mean():.2f} [{v['phi0_min_deg'].min():.2f}, {v['phi0_max_deg'].max():.2f}];"
                f" v tilt: {v['v_within_10'].mean():.3f} / {v['v_lean_10_45'].mean():.3f} / {v['capsized_v_1000'].mean():.3f}"
            )
    lines += ["", "capsize angle at t = 0 (phi of the principal axis nearest v, degrees), per run: mean [min, max];"]
    lines += ["  capsized at t = 0; the upright (v axis within 45°) icebergs' mean tilt at t = 1000:"]
    for r in rows:
        if r["status"] == "ok" and GROUPS[r["group"]][0] not in (None, 0.0):
            lines.append(
                f"  {r['group']:9s} seed {r['seed']}: {r['phi0_mean_deg']:.2f} [{r['phi0_min_deg']:.2f}, {r['phi0_max_deg']:.2f}]"
                f"  capsized {r['capsized_0']:.4f}; upright icebergs' mean tilt at t = 1000 {r['upright_tilt_deg_1000']:+.2f}"
            )
    (RESULTS / "shelf_cuts.log").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()

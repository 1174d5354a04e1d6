"""``melange-ti bench accuracy``: wall time per simulated time unit against error.

Configurations of dt, discs, precision and contact passes (one factor at a time around
dt 0.01 / 28 discs / f64 / 1 pass; ``--grid full`` for every combination), each precision
in its own worker process (:mod:`melange_ti.bench.worker`, because ``ti.init`` cannot be
repeated with another ``default_fp`` in one process). Errors against a reference ensemble of
the paper scene, and the physics studies' errors (:mod:`melange_ti.studies`: one iceberg
against closed forms, the largest stable dt) put next to the cost of each configuration.
Pareto plot.
"""

from __future__ import annotations

import itertools
import json
import math
import os
import subprocess
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .common import Options, plain_log_ticks, print_table, pyplot, write_csv

ACCURACY_COLUMNS = [
    "config",
    "dt",
    "discs",
    "precision",
    "passes",
    "n",
    "seeds",
    "duration",
    "reference",
    "ok",
    "mode",
    "cost_s_per_time",
    "cf_rms",
    "le_rms",
    "ensemble_error",
    "noise_floor",
    "roll_period_error",
    "capsize_energy_error",
    "energy_drift",
    "analytic_error",
    "pareto_ensemble",
    "pareto_analytic",
    "error",
]


@dataclass
class AccuracyPlan:
    dts: tuple[float, ...]
    discs: tuple[int, ...]
    precisions: tuple[str, ...]
    passes: tuple[int, ...]
    base: dict
    reference: dict
    n: int
    seeds: int
    duration: float
    every: float
    analytic: dict
    stable_single: dict
    stable_paper: dict


def accuracy_plan(o: Options) -> AccuracyPlan:
    if o.quick:
        return AccuracyPlan(
            dts=(0.04, 0.02),
            discs=(12,),
            precisions=("f64", "f32"),
            passes=(1,),
            base=dict(dt=0.04, discs=12, precision="f64", passes=1),
            reference=dict(dt=0.02, discs=12, precision="f64", passes=1),
            n=24,
            seeds=o.seeds or 2,
            duration=o.duration or 8.0,
            every=1.0,
            analytic=dict(roll_periods=2.5, drift_duration=10.0, capsize_duration=20.0, sample_every=0.1),
            stable_single=dict(ladder=[1.0, 4.0], refine=1, periods=10),
            stable_paper=dict(n=24, discs=12, duration=4.0, ladder=[0.02, 0.04], refine=0),
        )
    return AccuracyPlan(
        dts=(0.04, 0.02, 0.01, 0.005, 0.0025),
        discs=(12, 28, 60, 124),
        precisions=("f64", "f32"),
        passes=(1, 2, 4),
        base=dict(dt=0.01, discs=28, precision="f64", passes=1),
        # 124 discs: where the capsize statistics converge in the disc count (docs/validation.md)
        reference=dict(dt=0.0025, discs=124, precision="f64", passes=1),
        n=400,
        seeds=o.seeds or 4,
        duration=o.duration or 400.0,
        every=1.0,
        analytic=dict(roll_periods=10.5, drift_duration=300.0, capsize_duration=1500.0, sample_every=0.05),
        stable_single=dict(refine=6, periods=60),
        stable_paper=dict(n=400, discs=28, duration=200.0, refine=3),
    )


def _label(c: dict) -> str:
    return f"dt={c['dt']:g} discs={c['discs']} {c['precision']} passes={c['passes']}"


def accuracy_configs(plan: AccuracyPlan, grid: str) -> list[dict]:
    if grid == "full":
        configs = [
            dict(dt=a, discs=b, precision=c, passes=d)
            for a, b, c, d in itertools.product(plan.dts, plan.discs, plan.precisions, plan.passes)
        ]
    elif grid == "ofat":
        configs = [dict(plan.base, dt=v) for v in plan.dts] + [dict(plan.base, discs=v) for v in plan.discs]
        configs += [dict(plan.base, precision=v) for v in plan.precisions] + [dict(plan.base, passes=v) for v in plan.passes]
    else:
        raise ValueError(f"grid must be 'ofat' or 'full', not {grid!r}")
    configs.append(dict(plan.reference))
    unique = {}
    for c in configs:
        unique.setdefault(_label(c), c)
    return list(unique.values())


def _task_cost(t: dict) -> float:
    """Rough relative cost, for spreading tasks over worker processes."""
    if t["kind"] == "paper":
        return len(t["seeds"]) * t["duration"] / t["dt"] * t["n"] / 400 * (0.4 + t["discs"] / 28) * (1 + 0.3 * (t["passes"] - 1))
    if t["kind"] == "analytic":
        return (t.get("drift_duration", 300) + t.get("capsize_duration", 1500) / 10) / t["dt"] * 0.05 + 2e3
    if t["kind"] == "stable_single":
        return 2e4
    return t["duration"] / 0.01 * t["n"] / 400 * 2.5


def _split(tasks: list[dict], bins: int) -> list[list[dict]]:
    """Longest-processing-time-first assignment of tasks to ``bins`` lists."""
    bins = max(1, min(bins, len(tasks)))
    load = [0.0] * bins
    out: list[list[dict]] = [[] for _ in range(bins)]
    for t in sorted(tasks, key=_task_cost, reverse=True):
        k = int(np.argmin(load))
        out[k].append(t)
        load[k] += _task_cost(t)
    return out


def run_workers(tasks_by_precision: dict[str, list[dict]], jobs: int, threads: int = 1) -> list[dict]:
    """Run tasks in ``python -m melange_ti.bench.worker`` processes, ``jobs`` at a time."""
    total = sum(_task_cost(t) for ts in tasks_by_precision.values() for t in ts) or 1.0
    plans = []
    for precision, tasks in tasks_by_precision.items():
        if not tasks:
            continue
        share = sum(_task_cost(t) for t in tasks) / total
        for chunk in _split(tasks, max(1, round(jobs * share))):
            plans.append({"precision": precision, "threads": threads, "tasks": chunk})
    results: list[dict] = []
    with tempfile.TemporaryDirectory(prefix="melange_bench_") as d:

        def run(k: int) -> list[dict]:
            job = Path(d) / f"job{k}.json"
            res = Path(d) / f"result{k}.json"
            job.write_text(json.dumps(plans[k]))
            proc = subprocess.run(
                [sys.executable, "-m", "melange_ti.bench.worker", str(job), str(res)],
                stdout=subprocess.DEVNULL,
                stdin=subprocess.DEVNULL,
            )
            got = json.loads(res.read_text()) if res.exists() else []
            if proc.returncode not in (0, 1) or len(got) < len(plans[k]["tasks"]):
                done = {json.dumps(r["task"], sort_keys=True) for r in got}
                for t in plans[k]["tasks"]:
                    if json.dumps(t, sort_keys=True) not in done:
                        got.append(
                            {
                                "task": t,
                                "precision": plans[k]["precision"],
                                "ok": False,
                                "error": f"worker exited with status {proc.returncode} before this task finished",
                            }
                        )
            return got

        print(
            f"accuracy: {sum(len(p['tasks']) for p in plans)} tasks in {len(plans)} worker processes, {jobs} at a time",
            flush=True,
        )
        with ThreadPoolExecutor(max_workers=max(1, jobs)) as pool:
            for got in pool.map(run, range(len(plans))):
                results.extend(got)
    return results


def _pareto(points: list[tuple[float, float]]) -> list[bool]:
    """Non-dominated points when minimising both coordinates (non-finite: never on the front)."""
    flags = []
    for i, (c, e) in enumerate(points):
        if not (math.isfinite(c) and math.isfinite(e)):
            flags.append(False)
            continue
        dominated = any(
            math.isfinite(c2) and math.isfinite(e2) and c2 <= c and e2 <= e and (c2 < c or e2 < e)
            for j, (c2, e2) in enumerate(points)
            if j != i
        )
        flags.append(not dominated)
    return flags


def _ensemble(runs: list[dict], grid: np.ndarray, key: str) -> np.ndarray:
    """Curves of ``key`` on ``grid``, shape (seeds, len(grid)); NaN past a run's end."""
    out = np.full((len(runs), len(grid)), np.nan)
    for k, r in enumerate(runs):
        t = np.asarray(r["t"], dtype=float)
        y = np.asarray(r[key], dtype=float)
        if len(t) == 0:
            continue
        vals = np.interp(grid, t, y)
        vals[grid > t[-1] + 1e-9] = np.nan
        out[k] = vals
    return out


def run(out: Path, o: Options) -> int:
    plan = accuracy_plan(o)
    configs = accuracy_configs(plan, o.grid)
    ref_label = _label(plan.reference)
    seeds = list(range(1, plan.seeds + 1))
    jobs = o.jobs or min(2, os.cpu_count() or 1)
    tasks: dict[str, list[dict]] = {p: [] for p in ("f64", "f32")}
    for c in configs:
        tasks[c["precision"]].append(
            {
                "kind": "paper",
                "label": _label(c),
                "n": plan.n,
                "dt": c["dt"],
                "discs": c["discs"],
                "passes": c["passes"],
                "seeds": seeds,
                "duration": plan.duration,
                "every": plan.every,
            }
        )
    for dt, prec in sorted({(c["dt"], c["precision"]) for c in configs}):
        tasks[prec].append({"kind": "analytic", "label": f"dt={dt:g} {prec}", "dt": dt, **plan.analytic})
    tasks["f64"].append({"kind": "stable_single", "label": "single", **plan.stable_single})
    tasks["f64"].append({"kind": "stable_paper", "label": "paper", **plan.stable_paper})
    results = run_workers(tasks, jobs)

    by_kind: dict[str, dict[str, dict]] = {}
    for r in results:
        by_kind.setdefault(r["task"]["kind"], {})[r["task"].get("label", "")] = r
    grid = np.arange(0.0, plan.duration + 1e-9, plan.every)
    ref = by_kind.get("paper", {}).get(ref_label, {})
    ref_runs = ref.get("runs", [])
    ref_cf_all = _ensemble(ref_runs, grid, "cf") if ref_runs else np.full((1, len(grid)), np.nan)
    ref_le_all = _ensemble(ref_runs, grid, "le") if ref_runs else np.full((1, len(grid)), np.nan)
    ref_cf, ref_le = np.nanmean(ref_cf_all, axis=0), np.nanmean(ref_le_all, axis=0)
    cf_scale = max(float(np.nanmax(np.abs(ref_cf))) if np.any(np.isfinite(ref_cf)) else 0.0, 1.0 / plan.n)
    le_scale = max(float(np.nanmax(np.abs(ref_le))) if np.any(np.isfinite(ref_le)) else 0.0, 0.1)
    k = len(ref_runs)
    if k >= 2:
        cf_sd = np.nanstd(ref_cf_all, axis=0, ddof=1)
        le_sd = np.nanstd(ref_le_all, axis=0, ddof=1)
        floor = math.sqrt(2.0 / k) * max(
            float(np.sqrt(np.nanmean(cf_sd**2))) / cf_scale, float(np.sqrt(np.nanmean(le_sd**2))) / le_scale
        )
    else:
        floor = float("nan")

    rows = []
    curves = []
    for c in configs:
        lab = _label(c)
        res = by_kind.get("paper", {}).get(lab, {"runs": [], "ok": False, "error": "missing"})
        runs = res.get("runs", [])
        cf_all, le_all = _ensemble(runs, grid, "cf"), _ensemble(runs, grid, "le")
        complete = bool(runs) and res.get("ok", False) and not np.isnan(cf_all).any()
        if complete:
            cf_m, le_m = cf_all.mean(axis=0), le_all.mean(axis=0)
            cf_rms = float(np.sqrt(np.mean((cf_m - ref_cf) ** 2)))
            le_rms = float(np.sqrt(np.mean((le_m - ref_le) ** 2)))
            ens = max(cf_rms / cf_scale, le_rms / le_scale)
            for j, tt in enumerate(grid):
                curves.append(
                    {
                        "config": lab,
                        "t": float(tt),
                        "cf_mean": float(cf_m[j]),
                        "cf_std": float(np.std(cf_all[:, j])),
                        "le_mean": float(le_m[j]),
                        "le_std": float(np.std(le_all[:, j])),
                    }
                )
        else:
            cf_rms = le_rms = ens = float("inf")
        costs = [r["cost"] for r in runs if r.get("cost") is not None and math.isfinite(r["cost"])]
        an = by_kind.get("analytic", {}).get(f"dt={c['dt']:g} {c['precision']}", {})
        roll = an.get("roll_period_error", float("nan"))
        caps = an.get("capsize_energy_error", float("nan"))
        drift = an.get("energy_drift", float("nan"))
        vals = [v for v in (roll, caps, drift) if v is not None]
        analytic = max(vals) if vals and all(math.isfinite(v) for v in vals) else float("inf")
        is_ref = lab == ref_label
        rows.append(
            {
                **c,
                "config": lab,
                "n": plan.n,
                "seeds": len(runs),
                "duration": plan.duration,
                "reference": is_ref,
                "ok": complete and not an.get("error"),
                "mode": res.get("mode", ""),
                "cost_s_per_time": float(np.mean(costs)) if costs else float("nan"),
                "cf_rms": float("nan") if is_ref else cf_rms,
                "le_rms": float("nan") if is_ref else le_rms,
                "ensemble_error": float("nan") if is_ref else ens,
                "noise_floor": floor,
                "roll_period_error": roll,
                "capsize_energy_error": caps,
                "energy_drift": drift,
                "analytic_error": analytic,
                "error": "; ".join(e for e in (res.get("error", ""), an.get("error", "")) if e),
            }
        )
    ens_front = _pareto([(r["cost_s_per_time"], r["ensemble_error"]) for r in rows])
    an_front = _pareto([(r["cost_s_per_time"], r["analytic_error"]) for r in rows])
    for r, a, b in zip(rows, ens_front, an_front, strict=True):
        r["pareto_ensemble"], r["pareto_analytic"] = a, b
    write_csv(out / "accuracy.csv", rows, ACCURACY_COLUMNS)
    write_csv(out / "accuracy_curves.csv", curves, ["config", "t", "cf_mean", "cf_std", "le_mean", "le_std"])

    stab_rows = []
    for name, kind in (
        ("single iceberg heave/roll (drag off)", "stable_single"),
        (f"paper scene N={plan.stable_paper['n']}", "stable_paper"),
    ):
        r = by_kind.get(kind, {}).get("single" if kind == "stable_single" else "paper", {})
        for tr in r.get("tried", []):
            stab_rows.append(
                {
                    "test": name,
                    "dt": tr["dt"],
                    "stable": tr["stable"],
                    "reason": tr["reason"],
                    "largest_stable": r.get("largest_stable"),
                    "first_unstable": r.get("first_unstable"),
                    "predicted": r.get("predicted", float("nan")),
                }
            )
        if r.get("error"):
            stab_rows.append({"test": name, "reason": r["error"]})
    write_csv(
        out / "accuracy_stability.csv",
        stab_rows,
        ["test", "dt", "stable", "reason", "largest_stable", "first_unstable", "predicted"],
    )
    _plot(rows, curves, ref_label, floor, out / "accuracy.png")

    print_table(
        rows,
        [
            ("config", "config"),
            ("cost_s_per_time", "s/time unit"),
            ("ensemble_error", "ensemble err"),
            ("pareto_ensemble", "front"),
            ("roll_period_error", "roll T err"),
            ("capsize_energy_error", "capsize E err"),
            ("energy_drift", "E drift"),
            ("pareto_analytic", "front"),
        ],
        title=f"\naccuracy (paper scene N={plan.n}, {plan.seeds} seeds x {plan.duration:g} time units; reference {ref_label}; "
        f"ensemble noise floor {floor:.3g}):",
    )
    for kind, name in (
        ("stable_single", "single iceberg heave/roll"),
        ("stable_paper", f"paper scene N={plan.stable_paper['n']}"),
    ):
        r = next(iter(by_kind.get(kind, {}).values()), {})
        if not r or r.get("error"):
            print(f"largest stable dt, {name}: failed ({r.get('error', 'missing')})")
            continue
        hi = r.get("first_unstable")
        hi_text = (
            f", first unstable {hi:.4g}" if hi is not None and math.isfinite(hi) else " (no unstable dt found on the ladder)"
        )
        pred = r.get("predicted")
        pred_text = f"; linear prediction 2/omega = {pred:.4g}" if pred is not None and math.isfinite(pred) else ""
        print(f"largest stable dt, {name}: {r.get('largest_stable', float('nan')):.4g}{hi_text}{pred_text}")
    # A run that blows up is a result (an unstable configuration); a task that crashed, or a
    # worker that died, is a failure of the benchmark.
    bad = [r for r in results if "traceback" in r or "worker exited" in str(r.get("error", ""))]
    for r in bad:
        print(f"accuracy: task {r['task'].get('kind')} {r['task'].get('label', '')} failed: {r['error']}", file=sys.stderr)
    return 1 if bad else 0


def _plot(rows: list[dict], curves: list[dict], ref_label: str, floor: float, path: Path) -> None:
    plt = pyplot()
    fig, axes = plt.subplots(1, 3, figsize=(17, 5.2), constrained_layout=True)
    for ax, key, front_key, title in (
        (axes[0], "ensemble_error", "pareto_ensemble", "paper-scene ensemble error vs reference"),
        (axes[1], "analytic_error", "pareto_analytic", "single-iceberg error (worst of roll T, capsize E, E drift)"),
    ):
        pts = [(r["cost_s_per_time"], r[key], r) for r in rows if math.isfinite(r["cost_s_per_time"] or np.nan)]
        finite = [(c, e, r) for c, e, r in pts if math.isfinite(e) and e > 0]
        if finite:
            for c, e, r in finite:
                on = r[front_key]
                ax.loglog(c, e, "o", color="C3" if on else "C0", markersize=7 if on else 5, alpha=0.9 if on else 0.6)
                ax.annotate(r["config"].replace(" passes=", " p="), (c, e), fontsize=6, xytext=(3, 3), textcoords="offset points")
            front = sorted((c, e) for c, e, r in finite if r[front_key])
            if front:
                fx, fy = zip(*front, strict=True)
                ax.step(fx, fy, where="post", color="C3", lw=1.5, label="Pareto front")
        else:
            ax.text(
                0.5,
                0.5,
                "no positive finite errors\n(runs too short for any capsize?)",
                transform=ax.transAxes,
                ha="center",
                va="center",
                fontsize=9,
                color="gray",
            )
        if key == "ensemble_error" and math.isfinite(floor) and floor > 0:
            ax.axhline(floor, color="gray", ls="--", lw=1, label="ensemble noise floor")
        unstable = [r for r in rows if not math.isfinite(r[key] if r[key] is not None else np.nan) and not r["reference"]]
        if unstable:
            ax.text(
                0.02, 0.02, "no finite error: " + "; ".join(r["config"] for r in unstable), transform=ax.transAxes, fontsize=6
            )
        ax.set_xlabel("wall seconds per simulated time unit")
        ax.set_ylabel("relative error")
        plain_log_ticks(ax)
        ax.set_title(title, fontsize=10)
        ax.grid(True, which="both", alpha=0.3)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=8)
    ax = axes[2]
    configs = list(dict.fromkeys(c["config"] for c in curves))
    for lab in configs:
        sel = [c for c in curves if c["config"] == lab]
        t = np.array([c["t"] for c in sel])
        y = np.array([c["cf_mean"] for c in sel])
        if lab == ref_label:
            sd = np.array([c["cf_std"] for c in sel])
            ax.fill_between(t, y - sd, y + sd, color="k", alpha=0.15)
            ax.plot(t, y, "k-", lw=2, label=f"reference {lab}")
        else:
            ax.plot(t, y, lw=0.8, alpha=0.8, label=lab)
    ax.set_xlabel("time")
    ax.set_ylabel("ensemble-mean capsized fraction")
    ax.set_title("capsized fraction (reference: mean +- one seed-to-seed std)", fontsize=10)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=6)
    fig.savefig(path, dpi=110)
    plt.close(fig)

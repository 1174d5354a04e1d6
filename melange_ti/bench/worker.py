"""Worker process for ``melange-ti bench accuracy``: runs a list of tasks at one precision.

``ti.init`` cannot safely be repeated in one process, and f32 runs need Taichi initialised
with ``default_fp=f32``, so :mod:`melange_ti.bench.accuracy` starts one of these per
precision (and per parallel job)::

    python -m melange_ti.bench.worker JOB.json RESULT.json

``JOB.json`` is ``{"precision": "f64" | "f32", "threads": 1, "tasks": [{"kind": ...}, ...]}``;
``RESULT.json`` receives a list with one dict per task, in order, rewritten after every task
so that a crash keeps what finished. A task that raises is recorded with ``"error"``.

Task kinds (all times non-dimensional, docs/model.md):

``paper``      the paper scene (``n`` icebergs) with ``dt``, ``discs``, ``passes``, ``seed``
               for ``duration``; capsized fraction, leading edge and energy every ``every``;
               ``cost`` = wall seconds of ``advance`` per simulated time unit, the first
               interval (compilation) excluded; a run stops where the run's own guard would
               (:func:`melange_ti.energy.runaway`, a contact overflow).
``analytic``   one floating rectangle at ``dt``: roll period of a stable block, energy
               released by one capsize (drag on), energy drift with drag off
               (:func:`melange_ti.studies.single_iceberg_errors`).
``stable_single`` / ``stable_paper``
               the largest stable ``dt`` (:mod:`melange_ti.studies.stability`).

The physics of the last three is the studies'; this module only runs them at a precision.
"""

from __future__ import annotations

import json
import sys
import time
import traceback
from pathlib import Path

import numpy as np

from ..energy import runaway, total_energy
from ..errors import ContactOverflow
from .common import paper_scene, sync


# ---------------------------------------------------------------------------- paper scene
def task_paper(t: dict, precision: str) -> dict:
    """One configuration, every seed in ``seeds``, each from a new model (the kernels are
    compiled once per effect set and precision, not per model)."""
    from .. import diagnostics as dg
    from ..model import Model

    dt = float(t["dt"])
    seeds = [int(v) for v in t.get("seeds", [t.get("seed", 1)])]
    contacts = {"discs": t["discs"], "passes": t["passes"]}
    model = None
    runs = []
    for seed in seeds:
        sc = paper_scene(t["n"], precision=precision, dt=dt, duration=t["duration"], seed=seed, **contacts)
        model = Model(sc, mode=t.get("mode", "auto"))
        every = max(1, int(round(t.get("every", 1.0) / dt)))
        total = sc.time.steps
        s = model.sample()
        x0 = float(np.max(s["x"]))
        total_mass = float(model.constants()["mass"].sum())
        times, cf, le, energy = [0.0], [dg.capsized_fraction(s["theta"])], [0.0], [total_energy(s)]
        wall = 0.0
        timed_steps = 0
        step = 0
        ok, error = True, ""
        while step < total:
            k = min(every, total - step)
            t0 = time.perf_counter()
            try:
                model.advance(k)
                sync()
            except ContactOverflow as exc:
                ok, error = False, f"ContactOverflow: {exc}"
                break
            el = time.perf_counter() - t0
            if step > 0:  # not timed: the first seed's first interval compiles the kernels
                wall += el
                timed_steps += k
            step += k
            s = model.sample()
            e = total_energy(s)
            why = runaway(s, e, energy[0], total_mass)
            if why:
                ok, error = False, f"{why} at t = {step * dt:g}"
                break
            times.append(step * dt)
            cf.append(dg.capsized_fraction(s["theta"]))
            le.append(dg.leading_edge(s["x"], x0))
            energy.append(e)
        cost = wall / (timed_steps * dt) if timed_steps else float("nan")
        runs.append(
            {
                "seed": seed,
                "t": times,
                "cf": cf,
                "le": le,
                "energy": energy,
                "cost": cost,
                "steps": step,
                "ok": ok,
                "error": error,
            }
        )
    return {
        "runs": runs,
        "mode": model.mode if model is not None else "",
        "ok": all(r["ok"] for r in runs),
        "error": "; ".join(f"seed {r['seed']}: {r['error']}" for r in runs if r["error"]),
    }


# ---------------------------------------------------------------------------- the studies
ANALYTIC_KEYS = ("roll_periods", "drift_duration", "capsize_duration", "sample_every", "roll_amplitude")
SINGLE_KEYS = ("heave", "roll", "periods", "growth", "ladder", "refine")
PAPER_KEYS = ("n", "duration", "discs", "passes", "seed", "ladder", "refine")


def task_analytic(t: dict, precision: str) -> dict:
    from ..studies import single_iceberg_errors

    return single_iceberg_errors(float(t["dt"]), precision, **{k: t[k] for k in ANALYTIC_KEYS if k in t})


def task_stable_single(t: dict, precision: str) -> dict:
    from ..studies import largest_stable_dt_single

    return largest_stable_dt_single(precision, **{k: t[k] for k in SINGLE_KEYS if k in t})


def task_stable_paper(t: dict, precision: str) -> dict:
    from ..studies import largest_stable_dt_paper

    return largest_stable_dt_paper(precision=precision, **{k: t[k] for k in PAPER_KEYS if k in t})


TASKS = {
    "paper": task_paper,
    "analytic": task_analytic,
    "stable_single": task_stable_single,
    "stable_paper": task_stable_paper,
}


def _clean(v):
    if isinstance(v, dict):
        return {k: _clean(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_clean(x) for x in v]
    if isinstance(v, np.ndarray):
        return [_clean(x) for x in v.tolist()]
    if isinstance(v, (np.floating,)):
        return float(v)
    if isinstance(v, (np.integer,)):
        return int(v)
    if isinstance(v, np.bool_):
        return bool(v)
    return v


def run_job(job: dict, result_path: Path) -> int:
    from .. import runtime

    precision = job["precision"]
    runtime.init("cpu", job.get("threads", 1), precision)
    results = []
    failed = 0
    for task in job["tasks"]:
        t0 = time.perf_counter()
        try:
            res = TASKS[task["kind"]](task, precision)
        except Exception as exc:  # recorded, the other tasks still run
            failed += 1
            res = {"ok": False, "error": f"{exc.__class__.__name__}: {exc}", "traceback": traceback.format_exc()}
        res["task"] = task
        res["precision"] = precision
        res["seconds"] = time.perf_counter() - t0
        results.append(_clean(res))
        tmp = result_path.with_suffix(".tmp")
        tmp.write_text(json.dumps(results))
        tmp.replace(result_path)
        print(
            f"bench_worker[{precision}]: {task['kind']} {task.get('label', '')} done in {res['seconds']:.1f} s",
            file=sys.stderr,
            flush=True,
        )
    return 1 if failed else 0


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if len(argv) != 2:
        print("usage: python -m melange_ti.bench.worker JOB.json RESULT.json", file=sys.stderr)
        return 2
    job = json.loads(Path(argv[0]).read_text())
    return run_job(job, Path(argv[1]))


if __name__ == "__main__":
    sys.exit(main())

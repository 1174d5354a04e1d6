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
               interval (compilation) excluded.
``analytic``   one floating rectangle at ``dt``: roll period of a stable block, energy
               released by one capsize (drag on), energy drift with drag off.
``stable_single`` / ``stable_paper``
               scan ``dt`` upward (a ladder, then bisection) until the run blows up.
"""

from __future__ import annotations

import json
import math
import sys
import time
import traceback
from pathlib import Path

import numpy as np

from ..errors import ContactOverflow
from ..scene.keys import DENSITY_RATIO
from .common import STATE, dt_overrides, paper_scene, sync

R_DEFAULT = DENSITY_RATIO


def _energy(sample: dict, index=None) -> float:
    e = sample["kinetic"].astype(np.float64) + sample["potential"].astype(np.float64)
    return float(e.sum() if index is None else e[index])


def _finite(sample: dict) -> bool:
    return all(np.all(np.isfinite(sample[k])) for k in STATE)


def _intervals(model, total: int, every: int):
    """Advance ``model`` through ``total`` steps, ``every`` at a time; yield the step reached
    and the model's sample there."""
    step = 0
    while step < total:
        k = min(every, total - step)
        model.advance(k)
        step += k
        yield step, model.sample()


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
        times, cf, le, energy = [0.0], [dg.capsized_fraction(s["theta"])], [0.0], [_energy(s)]
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
            if not _finite(s):
                ok, error = False, f"non-finite state at t = {step * dt:g}"
                break
            times.append(step * dt)
            cf.append(dg.capsized_fraction(s["theta"]))
            le.append(dg.leading_edge(s["x"], x0))
            energy.append(_energy(s))
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


# ---------------------------------------------------------------------------- one iceberg
def single_scene(
    precision: str,
    dt: float,
    duration: float,
    bergs: list[dict],
    effects: list[str],
    drag: float = 0.01,
    density_ratio: float = R_DEFAULT,
):
    from .. import scene

    doc = {
        "scene": {"name": "bench_single", "effects": effects, "precision": precision},
        "physics": {"density_ratio": density_ratio, "drag": drag, "angular_drag": drag},
        "iceberg": bergs,
    }
    return scene.from_dict(doc, dt_overrides(dt, duration))


def _zero_crossing_period(t: np.ndarray, y: np.ndarray) -> float:
    """Period from the zero crossings of an oscillation (linear interpolation)."""
    sgn = np.signbit(y)
    idx = np.flatnonzero(sgn[1:] != sgn[:-1])
    if len(idx) < 3:
        return float("nan")
    y0, y1 = y[idx], y[idx + 1]
    tc = t[idx] + (t[idx + 1] - t[idx]) * y0 / (y0 - y1)
    return float(2.0 * (tc[-1] - tc[0]) / (len(tc) - 1))


def task_analytic(t: dict, precision: str) -> dict:
    """Roll period (stable block), capsize energy (drag on), energy drift (drag off)."""
    from .. import diagnostics as dg
    from ..scene import equilibrium_z
    from .peers import potential_energy

    r = R_DEFAULT
    dt = float(t["dt"])
    # Stable block: the paper iceberg lying flat (width 1.4, thickness 1), small roll.
    bw, bh, amp = 1.4, 1.0, float(t.get("roll_amplitude", 0.002))
    t_roll = float(dg.roll_period(r, bw, bh))
    # Capsizing iceberg: the paper's 1 x 1.4, upright with a small tilt (single_capsize scene).
    cw, ch, tilt = 1.0, 1.4, 0.01
    e_caps = float(dg.capsize_energy(r, cw, ch))
    roll_duration = float(t.get("roll_periods", 10.5)) * t_roll
    drift_duration = float(t.get("drift_duration", 300.0))
    span = max(roll_duration, drift_duration)
    bergs = [
        {"x": 0.0, "z": float(equilibrium_z(bh, r, 0.0)), "theta": amp, "width": bw, "thickness": bh},
        {"x": 10.0, "z": float(equilibrium_z(ch, r, 0.0)), "theta": tilt, "width": cw, "thickness": ch},
    ]
    from ..model import Model

    m = Model(single_scene(precision, dt, span, bergs, ["gravity", "buoyancy"]))
    every = max(1, int(round(float(t.get("sample_every", 0.05)) / dt)))
    total = int(round(span / dt))
    s = m.sample()
    ts, th, e1 = [0.0], [float(s["theta"][0])], [_energy(s, 1)]
    finite = True
    for step, s in _intervals(m, total, every):
        if not _finite(s):
            finite = False
            break
        ts.append(step * dt)
        th.append(float(s["theta"][0]))
        e1.append(_energy(s, 1))
    ts, th, e1 = np.array(ts), np.array(th), np.array(e1)
    in_roll = ts <= roll_duration
    period = _zero_crossing_period(ts[in_roll], th[in_roll]) if finite else float("nan")
    in_drift = ts <= drift_duration
    drift = float(np.max(np.abs(e1[in_drift] - e1[0])) / e_caps) if finite else float("inf")

    # Capsize with drag: energy released once the iceberg has settled flat.
    caps_duration = float(t.get("capsize_duration", 1500.0))
    m2 = Model(
        single_scene(precision, dt, caps_duration, [bergs[1]], ["gravity", "buoyancy", "drag"]),
    )
    s0 = m2.sample()
    m2.advance(int(round(caps_duration / dt)))
    s1 = m2.sample()
    released = _energy(s0) - _energy(s1)
    # Exact reference: the initial state's energy (f64, numpy) minus the flat rest state's;
    # upright-to-flat that is 0.5 r (1-r) w h (h-w); the 0.01 tilt changes it by ~2e-5.
    u0 = float(potential_energy(np.array([bergs[1]["z"]]), np.array([tilt]), cw, ch, r)[0])
    u_flat = float(potential_energy(np.array([equilibrium_z(cw, r, 0.0)]), np.array([math.pi / 2]), cw, ch, r)[0])
    exact = u0 - u_flat
    phi = float(dg.capsize_angle(s1["theta"])[0])
    return {
        "roll_period": period,
        "roll_period_analytic": t_roll,
        "roll_period_error": abs(period - t_roll) / t_roll if math.isfinite(period) else float("inf"),
        "capsize_released": released,
        "capsize_energy_analytic": e_caps,
        "capsize_energy_exact_start": exact,
        "capsize_energy_error": abs(released - exact) / exact if math.isfinite(released) else float("inf"),
        "capsize_final_phi": phi,
        "energy_drift": drift,
        "ok": bool(finite and math.isfinite(released)),
        "error": "" if finite else "non-finite single-iceberg state",
    }


# ---------------------------------------------------------------------------- stability
def _scan(test, ladder: list[float], refine: int) -> dict:
    """Largest stable dt: first unstable rung of ``ladder``, then bisection (geometric)."""
    tried = []
    lo = hi = None
    for dt in ladder:
        stable, why = test(dt)
        tried.append({"dt": dt, "stable": stable, "reason": why})
        if stable:
            lo = dt
        else:
            hi = dt
            break
    if lo is not None and hi is not None:
        for _ in range(refine):
            mid = math.sqrt(lo * hi)
            stable, why = test(mid)
            tried.append({"dt": mid, "stable": stable, "reason": why})
            if stable:
                lo = mid
            else:
                hi = mid
    return {
        "largest_stable": lo if lo is not None else float("nan"),
        "first_unstable": hi if hi is not None else float("nan"),
        "tried": tried,
    }


def task_stable_single(t: dict, precision: str) -> dict:
    """A stable floating block (1.4 x 1) released with heave and roll offsets, drag off.

    Unstable = non-finite, or the excitation energy above the rest state grows past
    ``growth`` (100) times its initial value. The offsets are tiny (1e-4) so that the motion
    stays linear (no corner leaves the water) until the growth is unmistakable; a stable
    semi-implicit Euler orbit exceeds its initial energy by at most
    (1 + w dt/2) / (1 - w dt/2), which is 100 only 1% below the linear limit w dt = 2.
    """
    from .. import diagnostics as dg
    from ..model import Model
    from ..scene import equilibrium_z
    from .peers import potential_energy

    r = R_DEFAULT
    bw, bh = 1.4, 1.0
    z_eq = float(equilibrium_z(bh, r, 0.0))
    u_eq = float(potential_energy(np.array([z_eq]), np.array([0.0]), bw, bh, r)[0])
    heave = float(t.get("heave", 1e-4))
    roll = float(t.get("roll", 1e-4))
    periods = float(t.get("periods", 60))
    growth = float(t.get("growth", 100.0))
    t_heave = float(dg.heave_period(r, bh))
    duration = periods * t_heave
    berg = {"x": 0.0, "z": z_eq + heave, "theta": roll, "width": bw, "thickness": bh}

    def test(dt: float):
        m = Model(single_scene(precision, dt, duration, [berg], ["gravity", "buoyancy"]))
        total = int(round(duration / dt))
        every = max(1, int(round(0.05 / dt)))
        e0 = _energy(m.sample()) - u_eq
        exc = []
        for step, s in _intervals(m, total, every):
            if not _finite(s):
                return False, f"non-finite at t = {step * dt:g}"
            exc.append(_energy(s) - u_eq)
            if abs(exc[-1]) > growth * e0:
                return False, f"excitation energy grew x{abs(exc[-1]) / e0:.3g} by t = {step * dt:g}"
        worst = float(np.max(np.abs(exc))) / e0
        return True, f"excitation energy at most x{worst:.3g} its initial value"

    ladder = [float(v) for v in t.get("ladder", [0.25, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 4.0])]
    out = _scan(test, ladder, int(t.get("refine", 6)))
    omega_heave = 2 * math.pi / t_heave
    omega_roll = 2 * math.pi / float(dg.roll_period(r, bw, bh))
    out["predicted"] = 2.0 / max(omega_heave, omega_roll)
    out["ok"] = True
    out["error"] = ""
    return out


def task_stable_paper(t: dict, precision: str) -> dict:
    """The paper scene: unstable = non-finite, contact overflow, or the total energy rising
    above its initial value by more than ``rise`` x (N x the energy of one capsize)."""
    from .. import diagnostics as dg
    from ..model import Model

    n = int(t["n"])
    duration = float(t["duration"])
    limit = float(t.get("rise", 0.05)) * n * float(dg.capsize_energy(R_DEFAULT, 1.0, 1.4))
    settings = {"discs": t.get("discs", 28), "passes": t.get("passes", 1), "seed": t.get("seed", 1)}

    def test(dt: float):
        m = Model(paper_scene(n, precision=precision, dt=dt, duration=duration, **settings))
        total = int(round(duration / dt))
        every = max(1, int(round(1.0 / dt)))
        e0 = _energy(m.sample())
        reached = 0
        worst = 0.0
        try:
            for reached, s in _intervals(m, total, every):
                if not _finite(s):
                    return False, f"non-finite at t = {reached * dt:g}"
                rise = _energy(s) - e0
                worst = max(worst, rise)
                if rise > limit:
                    return False, f"energy rose by {rise:.3g} > {limit:.3g} at t = {reached * dt:g}"
        except ContactOverflow:
            return False, f"contact overflow at t = {min(reached + every, total) * dt:g}"
        return True, f"largest energy rise {worst:.3g} (limit {limit:.3g})"

    ladder = [float(v) for v in t.get("ladder", [0.01, 0.02, 0.04, 0.08, 0.16, 0.32, 0.64, 1.28, 2.56])]
    out = _scan(test, ladder, int(t.get("refine", 3)))
    out["ok"] = True
    out["error"] = ""
    return out


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

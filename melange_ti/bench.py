"""Benchmarks: ``melange-ti bench scaling|accuracy|effects|peers [--out DIR] [--quick]``.

Each writes ``{out}/{which}.csv`` and ``{out}/{which}.png`` (plus a few side files named
``{which}_*.csv``) and prints a short table. Benchmarks measure; they never assert a speed.
Wall-clock figures vary 2-3x from run to run on a shared machine: compare ratios taken in one
run (see ``benchmarks/README.md``).

``scaling``   time per step and iceberg-steps per second for N = 400, 4000, 40000, 100000
              (the paper geometry, ``[shelf] count = N``), in the mode a run would use
              (``Model(mode="auto")``), and a breakdown by phase measured in the parallel mode
              where each phase is its own kernel (``ti.sync()`` around each). Two states:
              ``initial`` (the shelf as built: no contacts yet) and ``active`` (a 400-iceberg
              shelf evolved for 200 time units, mid-cascade, tiled N/400 times along x).
              Output = one ``sample()`` per diagnostic interval plus one HDF5 snapshot per
              snapshot interval, amortised per step. Exponents are least-squares slopes of
              log time against log N.
``accuracy``  wall time per simulated time unit against error for dt, discs, precision and
              contact passes (one factor at a time around dt 0.01 / 28 discs / f64 / 1 pass;
              ``--grid full`` for every combination), each precision in its own worker
              process (:mod:`melange_ti.bench_worker`). Errors against analytic
              single-iceberg results and against a reference ensemble of the paper scene;
              plus the largest stable dt. Pareto plot.
``effects``   cost per step of each effect: all effects, one dropped at a time, only
              gravity, none (paper scene, N = 400 and 4000, active state).
``peers``     the paper scene in pymunk (Chipmunk2D) with numpy buoyancy and drag
              (:mod:`melange_ti.bench_peers`) timed beside melange_ti in one run.

``python -m melange_ti.bench WHICH --help`` lists finer options (sizes, steps, seeds, ...).
"""

from __future__ import annotations

import argparse
import csv
import itertools
import json
import math
import os
import statistics
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import numpy as np

WHICH = ("scaling", "accuracy", "effects", "peers")
ALL_EFFECTS = ("gravity", "buoyancy", "drag", "collisions", "wall")
PHASES = ("forces", "broad", "narrow", "impulses", "integration", "correction", "other")
STATE = ("x", "z", "theta", "vx", "vz", "omega")
# Kernels of the parallel step, by phase. They are found by name, either as functions of
# melange_ti.physics.step (called as S.<name>) or as methods of Model (self._<name>), and
# wrapped with a timer while the phases are measured; the step itself is Model's own
# _step_parallel, so the breakdown follows whatever the engine does. Anything else the
# step does (unknown kernels, Python overhead) is reported as "other".
KERNEL_PHASE = {
    "kick_all": "forces",
    "reach_all": "broad",
    "bin_count": "broad",
    "bin_scan": "broad",
    "bin_fill": "broad",
    "detect_all": "narrow",
    "impulses": "impulses",
    "drift_all": "integration",
    "correct": "correction",
}


@dataclass
class Options:
    """Knobs of a benchmark; the ``melange-ti bench`` command sets only ``quick``."""

    quick: bool = False
    threads: int | None = None  # Taichi CPU threads (scaling, effects, peers); None = all
    sizes: tuple[int, ...] | None = None  # iceberg counts
    steps: int | None = None  # timed steps per block (default: by N)
    repeats: int = 3  # timed blocks; the median is reported
    block: int = 400  # icebergs in the evolved block the active state is tiled from
    pre_time: float | None = None  # time the block is evolved for (default 200)
    seeds: int | None = None  # accuracy: ensemble size
    duration: float | None = None  # accuracy: simulated time of each paper run
    jobs: int | None = None  # accuracy: worker processes at once
    grid: str = "ofat"  # accuracy: "ofat" (one factor at a time) or "full"

    @classmethod
    def from_args(cls, args) -> Options:
        o = cls()
        for name in cls.__dataclass_fields__:
            v = getattr(args, name, None)
            if v is not None:
                setattr(o, name, tuple(v) if isinstance(v, list) else v)
        return o


def main(args) -> int:
    """Entry point of ``melange-ti bench``; returns the exit status."""
    which = args.which
    if which not in WHICH:
        print(f"melange-ti: error: bench {which!r}: must be one of {', '.join(WHICH)}", file=sys.stderr)
        return 2
    out = Path(getattr(args, "out", None) or "benchmarks/results")
    out.mkdir(parents=True, exist_ok=True)
    opts = Options.from_args(args)
    t0 = time.perf_counter()
    status = {"scaling": bench_scaling, "accuracy": bench_accuracy, "effects": bench_effects, "peers": bench_peers}[which](
        out, opts
    )
    print(f"bench {which}: {time.perf_counter() - t0:.0f} s; results in {out / (which + '.csv')} and {out / (which + '.png')}")
    return status


# ============================================================================ common helpers
def _init(threads: int | None = None, precision: str = "f64") -> str:
    from . import runtime

    return runtime.init("cpu", threads, precision)


def _sync() -> None:
    import taichi as ti

    ti.sync()


def paper_scene(n: int, extra: list | None = None, dt: float = 0.01, precision: str = "f64"):
    """The bundled paper scene with ``count = n`` (and overrides)."""
    from .bench_worker import paper_scene as ps

    return ps(n, precision, dt, duration=max(dt, 1.0), extra=extra or [])


def _geometry(sc) -> dict[str, np.ndarray]:
    b = sc.icebergs()
    return {"width": np.asarray(b.width), "thickness": np.asarray(b.thickness)}


def initial_state(sc) -> dict[str, np.ndarray]:
    b = sc.icebergs()
    return {k: np.asarray(getattr(b, k), dtype=np.float64) for k in (*STATE, "width", "thickness")}


def evolved_block(block: int, pre_time: float, mode: str = "auto", dt: float = 0.01):
    """The paper shelf of ``block`` icebergs after ``pre_time``: (state with geometry, model)."""
    from .model import Model

    sc = paper_scene(block, dt=dt)
    model = Model(sc, mode=mode)
    model.advance(int(round(pre_time / dt)))
    state = {k: np.asarray(v, dtype=np.float64) for k, v in model.state().items()}
    state.update(_geometry(sc))
    return state, model


def tile(state: dict[str, np.ndarray], n: int, gap: float = 0.1) -> dict[str, np.ndarray]:
    """``n`` icebergs: copies of ``state`` side by side along x, cut to ``n``.

    Each copy is shifted by the block's extent along x (from its leftmost to its rightmost
    rectangle corner) plus ``gap``, so copies never overlap; the first copy is the block
    itself, against the wall.
    """
    x = state["x"]
    half = 0.5 * (np.abs(state["width"] * np.cos(state["theta"])) + np.abs(state["thickness"] * np.sin(state["theta"])))
    period = float(np.max(x + half) - np.min(x - half) + gap)
    reps = int(math.ceil(n / len(x)))
    out = {}
    for k, v in state.items():
        if k == "x":
            out[k] = np.concatenate([v + r * period for r in range(reps)])[:n]
        else:
            out[k] = np.tile(v, reps)[:n]
    return out


def _time_advance(model, steps: int, repeats: int) -> float:
    """Median wall seconds per step of ``model.advance(steps)`` over ``repeats`` blocks."""
    per = []
    for _ in range(max(1, repeats)):
        _sync()
        t0 = time.perf_counter()
        model.advance(steps)
        _sync()
        per.append((time.perf_counter() - t0) / steps)
    return statistics.median(per)


class _PhaseTimer:
    """Wraps the step's kernels with ``sync`` + ``perf_counter`` while active."""

    def __init__(self, model):
        import importlib

        self.acc = dict.fromkeys(PHASES, 0.0)
        self.targets = []
        try:
            step_module = importlib.import_module(".physics.step", __package__)
        except ImportError:
            step_module = None
        for name, phase in KERNEL_PHASE.items():
            if step_module is not None and callable(getattr(step_module, name, None)):
                self.targets.append((step_module, name, phase))
            if callable(getattr(model, "_" + name, None)):
                self.targets.append((model, "_" + name, phase))
        self.saved: list[tuple[object, str, object, bool]] = []

    def _wrap(self, fn, phase):
        import taichi as ti

        acc = self.acc
        clock = time.perf_counter

        def timed(*args, **kwargs):
            t0 = clock()
            out = fn(*args, **kwargs)
            ti.sync()
            acc[phase] += clock() - t0
            return out

        return timed

    def __enter__(self):
        for owner, name, phase in self.targets:
            fn = getattr(owner, name)
            had = name in getattr(owner, "__dict__", {})
            self.saved.append((owner, name, owner.__dict__.get(name) if had else None, had))
            setattr(owner, name, self._wrap(fn, phase))
        return self

    def __exit__(self, *exc):
        for owner, name, old, had in reversed(self.saved):
            if had:
                setattr(owner, name, old)
            else:
                delattr(owner, name)
        self.saved.clear()
        return False


def time_phases(model, steps: int) -> dict[str, float]:
    """Wall seconds per step of each phase of ``model._step_parallel`` (a sync after every
    kernel); ``other`` = the step's wall time minus the phases found."""
    timer = _PhaseTimer(model)
    total = 0.0
    model.prepare()
    _sync()
    with timer:
        for _ in range(steps):
            t0 = time.perf_counter()
            model._step_parallel()
            _sync()
            total += time.perf_counter() - t0
    found = sum(v for k, v in timer.acc.items() if k != "other")
    timer.acc["other"] = max(0.0, total - found)
    if not timer.targets:
        print("scaling: no phase kernels found in the engine; the whole step is reported as 'other'", file=sys.stderr)
    model.advance(1)  # the model's own overflow check (raises ContactOverflow)
    return {k: v / steps for k, v in timer.acc.items()}


def time_output(model, sc, repeats: int) -> dict[str, float]:
    """Cost of output: ``sample()`` and one HDF5 snapshot (RunWriter), and per step amortised
    over the scene's diagnostic and snapshot intervals."""
    from .io.hdf5 import RunWriter

    dtype = np.float32 if sc.precision == "f32" else np.float64
    t_sample, t_write = [], []
    with tempfile.TemporaryDirectory() as d:
        writer = RunWriter(Path(d) / "bench.h5", {"scene_toml": sc.to_toml()}, model.constants(), dtype)
        try:
            writer.snapshot(-1.0, model.sample())  # the first sample() compiles its kernel
            for k in range(max(2, repeats)):
                t0 = time.perf_counter()
                s = model.sample()
                t_sample.append(time.perf_counter() - t0)
                t0 = time.perf_counter()
                writer.snapshot(float(k), s)
                t_write.append(time.perf_counter() - t0)
        finally:
            writer.close()
    every_diag = max(1, round(sc.output.diagnostic_interval / sc.time.dt))
    every_snap = max(1, round(sc.output.snapshot_interval / sc.time.dt))
    ts, tw = statistics.median(t_sample), statistics.median(t_write)
    return {"sample": ts, "write": tw, "per_step": ts / every_diag + tw / every_snap}


def fit_exponent(n, y) -> tuple[float, float]:
    """Least squares ``log y = a + b log n``; returns ``(b, exp(a))`` (NaN if < 2 points)."""
    n, y = np.asarray(n, dtype=float), np.asarray(y, dtype=float)
    ok = np.isfinite(y) & (y > 0) & (n > 0)
    if np.count_nonzero(ok) < 2 or len(np.unique(n[ok])) < 2:
        return float("nan"), float("nan")
    b, a = np.polyfit(np.log(n[ok]), np.log(y[ok]), 1)
    return float(b), float(math.exp(a))


def write_csv(path: Path, rows: list[dict], columns: list[str]) -> None:
    with open(path, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=columns, extrasaction="ignore")
        w.writeheader()
        for r in rows:
            w.writerow({k: _fmt_csv(r.get(k, "")) for k in columns})


def _fmt_csv(v):
    if isinstance(v, float):
        return repr(v) if math.isfinite(v) else ("nan" if math.isnan(v) else ("inf" if v > 0 else "-inf"))
    if isinstance(v, bool):
        return "true" if v else "false"
    return v


def _fmt(v) -> str:
    if isinstance(v, bool):
        return "yes" if v else ""
    if isinstance(v, float):
        if not math.isfinite(v):
            return str(v)
        if v == 0:
            return "0"
        a = abs(v)
        if a >= 1e12 or a < 1e-3:
            return f"{v:.3g}"
        if a >= 100:
            return f"{v:,.0f}"
        return f"{v:.3g}"
    if isinstance(v, int) and abs(v) >= 10000:
        return f"{v:,}"
    return str(v)


def print_table(rows: list[dict], columns: list[tuple[str, str]], title: str | None = None) -> None:
    """A plain aligned table of ``rows``; ``columns`` are (key, heading) pairs."""
    cells = [[h for _, h in columns]] + [[_fmt(r.get(k, "")) for k, _ in columns] for r in rows]
    widths = [max(len(c[i]) for c in cells) for i in range(len(columns))]
    # text columns flush left, numbers flush right
    left = [not any(isinstance(r.get(k), (int, float)) and not isinstance(r.get(k), bool) for r in rows) for k, _ in columns]
    if title:
        print(title)
    for j, c in enumerate(cells):
        print("  ".join(s.ljust(w) if lf else s.rjust(w) for s, w, lf in zip(c, widths, left, strict=True)).rstrip())
        if j == 0:
            print("  ".join("-" * w for w in widths))


def _steps_for(n: int, quick: bool, override: int | None, work: float = 4e5, lo: int = 20, hi: int = 1000) -> int:
    if override:
        return int(override)
    if quick:
        return 20
    return int(max(lo, min(hi, work / n)))


def _log_limits(ax, values) -> None:
    v = np.asarray([x for x in values if x is not None and np.isfinite(x) and x > 0], dtype=float)
    if v.size:
        ax.set_ylim(v.min() / 3, v.max() * 4)


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _plain_log_ticks(ax) -> None:
    """Short tick labels on log axes that span less than two decades (the default labels
    every minor tick as ``2.5x10^-4``, which overlap)."""
    from matplotlib.ticker import FuncFormatter, NullFormatter

    short = FuncFormatter(lambda v, _: f"{v:.3g}")
    for axis, scale, lim in ((ax.xaxis, ax.get_xscale(), ax.get_xlim()), (ax.yaxis, ax.get_yscale(), ax.get_ylim())):
        if scale != "log" or min(lim) <= 0:
            continue
        if math.log10(max(lim) / min(lim)) < 2:
            axis.set_major_formatter(short)
            axis.set_minor_formatter(short)
        else:
            axis.set_minor_formatter(NullFormatter())
    for label in ax.get_xticklabels(which="both"):
        label.set_rotation(30)
        label.set_fontsize(7)


# ============================================================================ scaling
SERIAL_TIMED_MAX = 40000  # the serial mode is timed for comparison up to this N

SCALING_COLUMNS = [
    "n",
    "state",
    "mode",
    "steps",
    "ms_per_step",
    "iceberg_steps_per_s",
    "ms_per_step_with_output",
    "ms_per_step_serial",
    "ms_per_step_parallel",
    "impulses_per_step",
    "phase_forces_ms",
    "phase_broad_ms",
    "phase_narrow_ms",
    "phase_impulses_ms",
    "phase_integration_ms",
    "phase_correction_ms",
    "phase_other_ms",
    "phase_output_ms",
    "phase_sum_ms",
    "threads",
    "pre_time",
]


def bench_scaling(out: Path, o: Options) -> int:
    from .model import Model

    sizes = tuple(o.sizes or ((60, 240) if o.quick else (400, 4000, 40000, 100000)))
    _init(o.threads)
    import taichi as ti

    threads = o.threads or ti.lang.impl.current_cfg().cpu_max_num_threads
    pre = o.pre_time if o.pre_time is not None else (3.0 if o.quick else 200.0)
    block = min(o.block, min(sizes))
    repeats = 2 if o.quick else o.repeats
    print(f"scaling: evolving a {block}-iceberg shelf for {pre:g} time units (the active state) ...", flush=True)
    block_state, block_model = evolved_block(block, pre, mode="auto")
    rows = []
    for n in sizes:
        t_n = time.perf_counter()
        sc = paper_scene(n)
        steps = _steps_for(n, o.quick, o.steps)
        warm = 5 if o.quick else max(10, steps // 10)
        auto = block_model if n == block else Model(sc, mode="auto")
        # The mode auto did not pick, for comparison (serial only up to SERIAL_TIMED_MAX).
        other_mode = "parallel" if auto.mode == "serial" else "serial"
        other = Model(sc, mode=other_mode) if other_mode == "parallel" or n <= SERIAL_TIMED_MAX else None
        par = auto if auto.mode == "parallel" else other
        outp = time_output(auto, sc, 3 if o.quick else 5)
        for state_name, st in (("initial", initial_state(sc)), ("active", tile(block_state, n))):
            auto.set_state(st)
            auto.advance(warm)  # compiles on first use
            c0 = auto.totals().contacts
            s_step = _time_advance(auto, steps, repeats)
            imp = (auto.totals().contacts - c0) / (steps * repeats)
            by_mode = {auto.mode: s_step, other_mode: float("nan")}
            if other is not None:
                other.set_state(st)
                other.advance(warm)
                by_mode[other_mode] = _time_advance(other, steps, repeats)
            par.set_state(st)
            time_phases(par, warm)
            ph = time_phases(par, steps)
            row = {
                "n": n,
                "state": state_name,
                "mode": auto.mode,
                "steps": steps,
                "ms_per_step": 1e3 * s_step,
                "iceberg_steps_per_s": n / s_step,
                "ms_per_step_with_output": 1e3 * (s_step + outp["per_step"]),
                "ms_per_step_serial": 1e3 * by_mode["serial"],
                "ms_per_step_parallel": 1e3 * by_mode["parallel"],
                "impulses_per_step": imp,
                "threads": threads,
                "pre_time": pre if state_name == "active" else 0.0,
            }
            for p in PHASES:
                row[f"phase_{p}_ms"] = 1e3 * ph[p]
            row["phase_output_ms"] = 1e3 * outp["per_step"]
            row["phase_sum_ms"] = 1e3 * (sum(ph.values()) + outp["per_step"])
            rows.append(row)
        print(f"scaling: N = {n:,} done in {time.perf_counter() - t_n:.0f} s", flush=True)
    write_csv(out / "scaling.csv", rows, SCALING_COLUMNS)
    fits = []
    for state_name in ("initial", "active"):
        sel = [r for r in rows if r["state"] == state_name]
        quantities = ["ms_per_step", "ms_per_step_serial", "ms_per_step_parallel"]
        quantities += [f"phase_{p}_ms" for p in PHASES] + ["phase_output_ms", "phase_sum_ms"]
        for q in quantities:
            b, c = fit_exponent([r["n"] for r in sel], [r[q] for r in sel])
            fits.append({"state": state_name, "quantity": q, "exponent": b, "prefactor_ms": c})
    write_csv(out / "scaling_fit.csv", fits, ["state", "quantity", "exponent", "prefactor_ms"])
    _plot_scaling(rows, fits, out / "scaling.png")
    print_table(
        rows,
        [
            ("n", "N"),
            ("state", "state"),
            ("mode", "mode"),
            ("ms_per_step", "ms/step"),
            ("iceberg_steps_per_s", "iceberg-steps/s"),
            ("ms_per_step_serial", "serial"),
            ("ms_per_step_parallel", "parallel"),
            ("impulses_per_step", "impulses/step"),
            ("phase_forces_ms", "forces"),
            ("phase_broad_ms", "broad"),
            ("phase_narrow_ms", "narrow"),
            ("phase_impulses_ms", "impulses"),
            ("phase_integration_ms", "integr."),
            ("phase_correction_ms", "correct."),
            ("phase_output_ms", "output"),
        ],
        title="\nscaling (phases in ms/step, parallel mode with a sync after each kernel):",
    )
    for f in fits:
        if f["quantity"] in ("ms_per_step", "phase_sum_ms"):
            print(f"  {f['state']:7s} {f['quantity']:12s} ~ N^{f['exponent']:.2f}")
    return 0


def _plot_scaling(rows: list[dict], fits: list[dict], path: Path) -> None:
    plt = _pyplot()
    fit = {(f["state"], f["quantity"]): f for f in fits}
    fig, axes = plt.subplots(1, 2, figsize=(12, 5), constrained_layout=True)
    ax = axes[0]
    for state_name, marker in (("initial", "o"), ("active", "s")):
        sel = [r for r in rows if r["state"] == state_name]
        n = np.array([r["n"] for r in sel], dtype=float)
        y = np.array([r["ms_per_step"] for r in sel])
        f = fit[(state_name, "ms_per_step")]
        (line,) = ax.loglog(n, y, marker, markersize=8, label=f"{state_name}, auto mode: exponent {f['exponent']:.2f}")
        if math.isfinite(f["exponent"]):
            nn = np.geomspace(n.min(), n.max(), 50)
            ax.loglog(nn, f["prefactor_ms"] * nn ** f["exponent"], "-", color=line.get_color(), alpha=0.6)
        for mode, style in (("serial", ":"), ("parallel", "--")):
            ym = np.array([r[f"ms_per_step_{mode}"] for r in sel], dtype=float)
            if np.any(np.isfinite(ym)):
                ax.loglog(n, ym, style, color=line.get_color(), alpha=0.8, lw=1, label=f"{state_name}, {mode}")
    ax.set_xlabel("icebergs N")
    ax.set_ylabel("wall ms per step")
    ax.set_title("time per step (auto = serial up to SERIAL_MAX_N, else parallel)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    ax = axes[1]
    sel = [r for r in rows if r["state"] == "active"]
    n = np.array([r["n"] for r in sel], dtype=float)
    for p in [*PHASES, "output", "sum"]:
        q = f"phase_{p}_ms"
        y = np.array([r[q] for r in sel])
        if not np.any(y > 0):
            continue
        f = fit.get(("active", q), {"exponent": float("nan")})
        ax.loglog(n, y, "-o" if p != "sum" else "k--", label=f"{p}: {f['exponent']:.2f}", markersize=4)
    ax.set_xlabel("icebergs N")
    ax.set_ylabel("wall ms per step")
    ax.set_title("phases (parallel mode, active state), fitted exponents")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    for a in axes:
        _plain_log_ticks(a)
    fig.savefig(path, dpi=110)
    plt.close(fig)


# ============================================================================ effects
def effect_configs(quick: bool) -> list[tuple[str, list[str]]]:
    allx = list(ALL_EFFECTS)
    if quick:
        return [("all", allx), ("no collisions", [e for e in allx if e != "collisions"]), ("none", [])]
    return (
        [("all", allx)] + [(f"no {e}", [x for x in allx if x != e]) for e in allx] + [("only gravity", ["gravity"]), ("none", [])]
    )


EFFECTS_COLUMNS = ["n", "config", "effects", "mode", "steps", "ms_per_step", "saving_vs_all_ms", "fraction_of_all", "threads"]


def bench_effects(out: Path, o: Options) -> int:
    from .model import Model

    sizes = tuple(o.sizes or ((40,) if o.quick else (400, 4000)))
    _init(o.threads)
    import taichi as ti

    threads = o.threads or ti.lang.impl.current_cfg().cpu_max_num_threads
    pre = o.pre_time if o.pre_time is not None else (3.0 if o.quick else 200.0)
    block = min(o.block, min(sizes))
    repeats = 2 if o.quick else o.repeats
    print(f"effects: evolving a {block}-iceberg shelf for {pre:g} time units (the active state) ...", flush=True)
    block_state, block_model = evolved_block(block, pre)
    rows = []
    for n in sizes:
        state = tile(block_state, n)
        steps = _steps_for(n, o.quick, o.steps)
        warm = 5 if o.quick else max(10, steps // 10)
        for label, eff in effect_configs(o.quick):
            sc = paper_scene(n, extra=[("scene.effects", eff)])
            if label == "all" and n == block:
                model = block_model
            else:
                model = Model(sc, mode="auto")
            model.set_state(state)
            model.advance(warm)
            s_step = _time_advance(model, steps, repeats)
            rows.append(
                {
                    "n": n,
                    "config": label,
                    "effects": " ".join(eff) or "-",
                    "mode": model.mode,
                    "steps": steps,
                    "ms_per_step": 1e3 * s_step,
                    "threads": threads,
                }
            )
            print(f"effects: N = {n:,} {label}: {1e3 * s_step:.3g} ms/step", flush=True)
        t_all = next(r["ms_per_step"] for r in rows if r["n"] == n and r["config"] == "all")
        for r in rows:
            if r["n"] == n:
                r["saving_vs_all_ms"] = t_all - r["ms_per_step"]
                r["fraction_of_all"] = r["ms_per_step"] / t_all
    write_csv(out / "effects.csv", rows, EFFECTS_COLUMNS)
    _plot_effects(rows, out / "effects.png")
    print_table(
        rows,
        [
            ("n", "N"),
            ("config", "effects"),
            ("mode", "mode"),
            ("ms_per_step", "ms/step"),
            ("saving_vs_all_ms", "saved vs all (ms)"),
            ("fraction_of_all", "fraction of all"),
        ],
        title="\neffects (paper scene, active state; 'no X' saves the cost of X):",
    )
    return 0


def _plot_effects(rows: list[dict], path: Path) -> None:
    plt = _pyplot()
    sizes = sorted({r["n"] for r in rows})
    labels = list(dict.fromkeys(r["config"] for r in rows))
    fig, ax = plt.subplots(figsize=(max(7, 1.1 * len(labels) + 3), 4.8), constrained_layout=True)
    width = 0.8 / len(sizes)
    for k, n in enumerate(sizes):
        y = [next((r["ms_per_step"] for r in rows if r["n"] == n and r["config"] == lab), np.nan) for lab in labels]
        pos = np.arange(len(labels)) + (k - (len(sizes) - 1) / 2) * width
        bars = ax.bar(pos, y, width, label=f"N = {n:,}")
        for b, v in zip(bars, y, strict=True):
            ax.annotate(f"{v:.3g}", (b.get_x() + b.get_width() / 2, v), ha="center", va="bottom", fontsize=7)
    ax.set_xticks(np.arange(len(labels)), labels, rotation=20)
    ax.set_yscale("log")
    _log_limits(ax, [r["ms_per_step"] for r in rows])
    ax.set_ylabel("wall ms per step")
    ax.set_title("cost of each effect (paper scene; an effect left out is not compiled)")
    ax.legend()
    ax.grid(True, axis="y", which="both", alpha=0.3)
    fig.savefig(path, dpi=110)
    plt.close(fig)


# ============================================================================ peers
PEERS_COLUMNS = [
    "n",
    "state",
    "engine",
    "version",
    "steps",
    "ms_per_step",
    "iceberg_steps_per_s",
    "ratio_vs_melange_ti",
    "threads",
]


def bench_peers(out: Path, o: Options) -> int:
    from . import __version__
    from .bench_peers import PymunkMelange, have_pymunk
    from .model import Model

    sizes = tuple(o.sizes or ((40,) if o.quick else (400, 4000)))
    _init(o.threads)
    import taichi as ti

    threads = o.threads or ti.lang.impl.current_cfg().cpu_max_num_threads
    peer = have_pymunk()
    pm_version = ""
    if peer:
        import pymunk

        pm_version = f"pymunk {pymunk.version} (Chipmunk {pymunk.chipmunk_version.split('-')[0]})"
    else:
        print("peers: pymunk is not installed (pip install 'melange_ti[peers]'); timing melange_ti only", file=sys.stderr)
    pre = o.pre_time if o.pre_time is not None else (3.0 if o.quick else 200.0)
    block = min(o.block, min(sizes))
    repeats = 2 if o.quick else o.repeats
    print(f"peers: evolving a {block}-iceberg shelf for {pre:g} time units (the active state) ...", flush=True)
    block_state, block_model = evolved_block(block, pre)
    rows = []
    for n in sizes:
        sc = paper_scene(n)
        p = sc.physics
        steps = _steps_for(n, o.quick, o.steps)
        psteps = _steps_for(n, o.quick, o.steps, work=2e5, hi=500)
        warm = 5 if o.quick else max(10, steps // 10)
        model = block_model if n == block else Model(sc, mode="auto")
        for state_name, st in (("initial", initial_state(sc)), ("active", tile(block_state, n))):
            model.set_state(st)
            model.advance(warm)
            ours = _time_advance(model, steps, repeats)
            rows.append(
                {
                    "n": n,
                    "state": state_name,
                    "engine": "melange_ti",
                    "version": f"melange_ti {__version__} ({model.mode})",
                    "steps": steps,
                    "ms_per_step": 1e3 * ours,
                    "iceberg_steps_per_s": n / ours,
                    "ratio_vs_melange_ti": 1.0,
                    "threads": threads,
                }
            )
            if peer:
                sim = PymunkMelange(
                    st,
                    density_ratio=p.density_ratio,
                    restitution=p.restitution,
                    drag=p.drag,
                    angular_drag=p.angular_drag,
                    water_level=p.water_level,
                    wall_x=p.wall_x,
                    dt=sc.time.dt,
                )
                sim.advance(warm)
                per = []
                for _ in range(repeats):
                    t0 = time.perf_counter()
                    sim.advance(psteps)
                    per.append((time.perf_counter() - t0) / psteps)
                theirs = statistics.median(per)
                rows.append(
                    {
                        "n": n,
                        "state": state_name,
                        "engine": "pymunk+numpy",
                        "version": pm_version,
                        "steps": psteps,
                        "ms_per_step": 1e3 * theirs,
                        "iceberg_steps_per_s": n / theirs,
                        "ratio_vs_melange_ti": theirs / ours,
                        "threads": 1,
                    }
                )
                print(
                    f"peers: N = {n:,} {state_name}: melange_ti {1e3 * ours:.3g} ms/step, pymunk {1e3 * theirs:.3g} ms/step, "
                    f"ratio {theirs / ours:.2f}",
                    flush=True,
                )
    write_csv(out / "peers.csv", rows, PEERS_COLUMNS)
    _plot_peers(rows, out / "peers.png")
    print_table(
        rows,
        [
            ("n", "N"),
            ("state", "state"),
            ("engine", "engine"),
            ("ms_per_step", "ms/step"),
            ("iceberg_steps_per_s", "iceberg-steps/s"),
            ("ratio_vs_melange_ti", "time / melange_ti"),
        ],
        title="\npeers (paper scene, same state for both; ratio > 1: the peer is slower):",
    )
    return 0


def _plot_peers(rows: list[dict], path: Path) -> None:
    plt = _pyplot()
    groups = list(dict.fromkeys((r["n"], r["state"]) for r in rows))
    engines = list(dict.fromkeys(r["engine"] for r in rows))
    fig, ax = plt.subplots(figsize=(max(6, 1.6 * len(groups) + 2), 4.8), constrained_layout=True)
    width = 0.8 / len(engines)
    for k, eng in enumerate(engines):
        y = [next((r["ms_per_step"] for r in rows if (r["n"], r["state"]) == g and r["engine"] == eng), np.nan) for g in groups]
        pos = np.arange(len(groups)) + (k - (len(engines) - 1) / 2) * width
        bars = ax.bar(pos, y, width, label=eng)
        for b, g, v in zip(bars, groups, y, strict=True):
            if not np.isfinite(v):
                continue
            ratio = next((r["ratio_vs_melange_ti"] for r in rows if (r["n"], r["state"]) == g and r["engine"] == eng), 1.0)
            text = f"{v:.3g}" if eng == "melange_ti" else f"{v:.3g}\n(x{ratio:.2g})"
            ax.annotate(text, (b.get_x() + b.get_width() / 2, v), ha="center", va="bottom", fontsize=8)
    ax.set_xticks(np.arange(len(groups)), [f"N = {n:,}\n{s}" for n, s in groups])
    ax.set_yscale("log")
    _log_limits(ax, [r["ms_per_step"] for r in rows])
    ax.set_ylabel("wall ms per step")
    ax.set_title("paper scene: melange_ti vs pymunk + numpy buoyancy/drag")
    ax.legend()
    ax.grid(True, axis="y", which="both", alpha=0.3)
    fig.savefig(path, dpi=110)
    plt.close(fig)


# ============================================================================ accuracy
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
        discs=(12, 28, 60),
        precisions=("f64", "f32"),
        passes=(1, 2, 4),
        base=dict(dt=0.01, discs=28, precision="f64", passes=1),
        reference=dict(dt=0.0025, discs=60, precision="f64", passes=1),
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
    """Run tasks in ``python -m melange_ti.bench_worker`` processes, ``jobs`` at a time."""
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
                [sys.executable, "-m", "melange_ti.bench_worker", str(job), str(res)],
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


def bench_accuracy(out: Path, o: Options) -> int:
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
    _plot_accuracy(rows, curves, ref_label, floor, out / "accuracy.png")

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


def _plot_accuracy(rows: list[dict], curves: list[dict], ref_label: str, floor: float, path: Path) -> None:
    plt = _pyplot()
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
        _plain_log_ticks(ax)
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


# ============================================================================ stand-alone
def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m melange_ti.bench", description="melange_ti benchmarks with finer options.")
    p.add_argument("which", choices=WHICH)
    p.add_argument("--out", default="benchmarks/results")
    p.add_argument("--quick", action="store_true", help="a tiny smoke run")
    p.add_argument("--threads", type=int, help="Taichi CPU threads for scaling/effects/peers (default: all)")
    p.add_argument("--sizes", type=lambda s: [int(v) for v in s.split(",")], help="iceberg counts, e.g. 400,4000")
    p.add_argument("--steps", type=int, help="timed steps per block (default: by N)")
    p.add_argument("--repeats", type=int, help="timed blocks per measurement (median; default 3)")
    p.add_argument("--block", type=int, help="icebergs in the evolved block tiled into the active state (default 400)")
    p.add_argument("--pre-time", dest="pre_time", type=float, help="time the block is evolved for (default 200)")
    p.add_argument("--seeds", type=int, help="accuracy: ensemble size (default 4)")
    p.add_argument("--duration", type=float, help="accuracy: simulated time per paper run (default 400)")
    p.add_argument("--jobs", type=int, help="accuracy: worker processes at once (default 2)")
    p.add_argument("--grid", choices=("ofat", "full"), help="accuracy: one factor at a time (default) or every combination")
    return p


if __name__ == "__main__":
    sys.exit(main(build_parser().parse_args()))

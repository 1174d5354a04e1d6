"""``melange-ti bench scaling``: time per step against N, by stage, with output.

For N = 400, 4000, 40000, 100000 (the paper geometry, ``[shelf] count = N``): time per step
in the mode a run would use (``Model(mode="auto")``) and in the other mode, and a breakdown
by stage from the parallel-mode model's ``Model.profile`` (a ``ti.sync()`` after each
stage). Two states: ``initial`` (the shelf as built) and ``active`` (a 400-iceberg shelf
evolved for 200 time units, tiled N/400 times along x). Output = one ``sample()`` per
diagnostic interval plus one HDF5 snapshot per snapshot interval, amortised per step.
Exponents are least-squares slopes of log time against log N.
"""

from __future__ import annotations

import math
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from .common import (
    Options,
    evolved_block,
    init,
    initial_state,
    paper_scene,
    plain_log_ticks,
    print_table,
    pyplot,
    steps_for,
    tile,
    time_advance,
    write_csv,
)

SERIAL_TIMED_MAX = 40000  # the serial mode is timed for comparison up to this N


def phases() -> tuple[str, ...]:
    """The stages of ``Model.profile`` plus ``"other"`` (the step's time outside them).

    A function, not a constant, so that importing this module does not import the physics.
    """
    from ..physics.stages import STAGE_NAMES

    return (*STAGE_NAMES, "other")


def columns() -> list[str]:
    """The columns of ``scaling.csv``."""
    head = ["n", "state", "mode", "steps", "ms_per_step", "iceberg_steps_per_s", "ms_per_step_with_output"]
    head += ["ms_per_step_serial", "ms_per_step_parallel", "impulses_per_step"]
    return [*head, *(f"phase_{p}_ms" for p in phases()), "phase_output_ms", "phase_sum_ms", "threads", "pre_time"]


def time_output(model, sc, repeats: int) -> dict[str, float]:
    """Cost of output: ``sample()`` and one HDF5 snapshot (RunWriter), and per step amortised
    over the scene's diagnostic and snapshot intervals."""
    from ..io.hdf5 import SCENE_ATTR, RunWriter

    dtype = np.float32 if sc.precision == "f32" else np.float64
    t_sample, t_write = [], []
    with tempfile.TemporaryDirectory() as d:
        writer = RunWriter(Path(d) / "bench.h5", {SCENE_ATTR: sc.to_toml()}, model.constants(), dtype)
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


def run(out: Path, o: Options) -> int:
    from ..model import Model

    sizes = tuple(o.sizes or ((60, 240) if o.quick else (400, 4000, 40000, 100000)))
    threads = init(o.threads)
    stage_cols = phases()
    pre = o.pre_time if o.pre_time is not None else (3.0 if o.quick else 200.0)
    block = min(o.block, min(sizes))
    repeats = 2 if o.quick else o.repeats
    print(f"scaling: evolving a {block}-iceberg shelf for {pre:g} time units (the active state) ...", flush=True)
    block_state, block_model = evolved_block(block, pre, mode="auto")
    rows = []
    for n in sizes:
        t_n = time.perf_counter()
        sc = paper_scene(n)
        steps = steps_for(n, o.quick, o.steps)
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
            c0 = auto.totals().impulses
            s_step = time_advance(auto, steps, repeats)
            imp = (auto.totals().impulses - c0) / (steps * repeats)
            by_mode = {auto.mode: s_step, other_mode: float("nan")}
            if other is not None:
                other.set_state(st)
                other.advance(warm)
                by_mode[other_mode] = time_advance(other, steps, repeats)
            par.set_state(st)
            par.profile(warm)
            ph = par.profile(steps)
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
            for p in stage_cols:
                row[f"phase_{p}_ms"] = 1e3 * ph[p]
            row["phase_output_ms"] = 1e3 * outp["per_step"]
            row["phase_sum_ms"] = 1e3 * (sum(ph[p] for p in stage_cols) + outp["per_step"])
            rows.append(row)
        print(f"scaling: N = {n:,} done in {time.perf_counter() - t_n:.0f} s", flush=True)
    write_csv(out / "scaling.csv", rows, columns())
    fits = []
    for state_name in ("initial", "active"):
        sel = [r for r in rows if r["state"] == state_name]
        quantities = ["ms_per_step", "ms_per_step_serial", "ms_per_step_parallel"]
        quantities += [f"phase_{p}_ms" for p in stage_cols] + ["phase_output_ms", "phase_sum_ms"]
        for q in quantities:
            b, c = fit_exponent([r["n"] for r in sel], [r[q] for r in sel])
            fits.append({"state": state_name, "quantity": q, "exponent": b, "prefactor_ms": c})
    write_csv(out / "scaling_fit.csv", fits, ["state", "quantity", "exponent", "prefactor_ms"])
    _plot(rows, fits, stage_cols, out / "scaling.png")
    stages = [(f"phase_{p}_ms", p if len(p) <= 8 else p[:7] + ".") for p in stage_cols if p != "other"]
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
            *stages,
            ("phase_output_ms", "output"),
        ],
        title="\nscaling (stages in ms/step: Model.profile, parallel form with a sync after each stage):",
    )
    for f in fits:
        if f["quantity"] in ("ms_per_step", "phase_sum_ms"):
            print(f"  {f['state']:7s} {f['quantity']:12s} ~ N^{f['exponent']:.2f}")
    return 0


def _plot(rows: list[dict], fits: list[dict], stage_cols: tuple[str, ...], path: Path) -> None:
    plt = pyplot()
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
    for p in [*stage_cols, "output", "sum"]:
        q = f"phase_{p}_ms"
        y = np.array([r[q] for r in sel])
        if not np.any(y > 0):
            continue
        f = fit.get(("active", q), {"exponent": float("nan")})
        ax.loglog(n, y, "-o" if p != "sum" else "k--", label=f"{p}: {f['exponent']:.2f}", markersize=4)
    ax.set_xlabel("icebergs N")
    ax.set_ylabel("wall ms per step")
    ax.set_title("stages (Model.profile, active state), fitted exponents")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    for a in axes:
        plain_log_ticks(a)
    fig.savefig(path, dpi=110)
    plt.close(fig)

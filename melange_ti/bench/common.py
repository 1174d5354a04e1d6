"""What the benchmark subcommands share: options, scenes and states, timing, CSV, tables, plots.

Nothing here imports Taichi or matplotlib at import time. The scenes are the studies' own
(:mod:`melange_ti.studies.scenes`): the benchmarks time what the studies check.
"""

from __future__ import annotations

import csv
import math
import statistics
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..studies.scenes import paper_scene

STATE = ("x", "z", "theta", "vx", "vz", "omega")


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


# ============================================================================ Taichi
def init(threads: int | None = None, precision: str = "f64") -> int:
    """Initialise Taichi on the CPU; returns the number of CPU threads it uses."""
    from .. import runtime

    runtime.init("cpu", threads, precision)
    if threads:
        return threads
    import taichi as ti

    return ti.lang.impl.current_cfg().cpu_max_num_threads


def sync() -> None:
    import taichi as ti

    ti.sync()


# ============================================================================ scenes and states
def initial_state(sc) -> dict[str, np.ndarray]:
    """The scene's initial state with geometry (``width``, ``thickness``), float64."""
    b = sc.icebergs()
    return {k: np.asarray(getattr(b, k), dtype=np.float64) for k in (*STATE, "width", "thickness")}


def evolved_block(block: int, pre_time: float, mode: str = "auto", dt: float = 0.01):
    """The paper shelf of ``block`` icebergs after ``pre_time``: (state with geometry, model)."""
    from ..model import Model

    sc = paper_scene(block, dt=dt)
    model = Model(sc, mode=mode)
    model.advance(int(round(pre_time / dt)))
    state = {k: np.asarray(v, dtype=np.float64) for k, v in model.state().items()}
    b = sc.icebergs()
    state.update(width=np.asarray(b.width), thickness=np.asarray(b.thickness))
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


# ============================================================================ timing
def time_advance(model, steps: int, repeats: int, pick=statistics.median) -> float:
    """Wall seconds per step of ``model.advance(steps)``: the median (or ``pick``) over
    ``repeats`` blocks."""
    per = []
    for _ in range(max(1, repeats)):
        sync()
        t0 = time.perf_counter()
        model.advance(steps)
        sync()
        per.append((time.perf_counter() - t0) / steps)
    return pick(per)


def steps_for(n: int, quick: bool, override: int | None, work: float = 4e5, lo: int = 20, hi: int = 1000) -> int:
    """Timed steps per block for ``n`` icebergs: about ``work / n``, within ``[lo, hi]``."""
    if override:
        return int(override)
    if quick:
        return 20
    return int(max(lo, min(hi, work / n)))


# ============================================================================ CSV and tables
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


# ============================================================================ plots
def pyplot():
    """matplotlib.pyplot on the headless Agg backend."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def log_limits(ax, values) -> None:
    v = np.asarray([x for x in values if x is not None and np.isfinite(x) and x > 0], dtype=float)
    if v.size:
        ax.set_ylim(v.min() / 3, v.max() * 4)


def save_ms_bars(plt, fig, ax, rows: list[dict], title: str, path: Path) -> None:
    """Finish a bar chart of ``ms_per_step`` (log axis, legend, grid) and write it to ``path``."""
    ax.set_yscale("log")
    log_limits(ax, [r["ms_per_step"] for r in rows])
    ax.set_ylabel("wall ms per step")
    ax.set_title(title)
    ax.legend()
    ax.grid(True, axis="y", which="both", alpha=0.3)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plain_log_ticks(ax) -> None:
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

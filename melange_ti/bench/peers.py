"""``melange-ti bench peers``: melange_ti and the pymunk peer timed on the same scene and the
same states (``initial`` and ``active``, as ``bench scaling``) in one run.

The peer, the paper scene written with pymunk (Chipmunk2D) and numpy buoyancy and drag, is
:class:`melange_ti.studies.peer.PymunkMelange` (what it differs in is said there); the
validation uses it too (``validation/capsize_peer.py``). pymunk is optional
(``pip install "melange_ti[peers]"``); without it only melange_ti is timed.
"""

from __future__ import annotations

import statistics
import sys
import time
from pathlib import Path

import numpy as np

from ..studies.peer import PymunkMelange, have_pymunk
from .common import (
    Options,
    evolved_block,
    init,
    initial_state,
    paper_scene,
    print_table,
    pyplot,
    save_ms_bars,
    steps_for,
    tile,
    time_advance,
    write_csv,
)

# ============================================================================ the subcommand
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


def run(out: Path, o: Options) -> int:
    from .. import __version__
    from ..model import Model

    sizes = tuple(o.sizes or ((40,) if o.quick else (400, 4000)))
    threads = init(o.threads)
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
        steps = steps_for(n, o.quick, o.steps)
        psteps = steps_for(n, o.quick, o.steps, work=2e5, hi=500)
        warm = 5 if o.quick else max(10, steps // 10)
        model = block_model if n == block else Model(sc, mode="auto")
        for state_name, st in (("initial", initial_state(sc)), ("active", tile(block_state, n))):
            model.set_state(st)
            model.advance(warm)
            ours = time_advance(model, steps, repeats)
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
                sim = PymunkMelange.for_scene(st, sc)
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
    _plot(rows, out / "peers.png")
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


def _plot(rows: list[dict], path: Path) -> None:
    plt = pyplot()
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
    save_ms_bars(plt, fig, ax, rows, "paper scene: melange_ti vs pymunk + numpy buoyancy/drag", path)

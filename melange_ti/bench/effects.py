"""``melange-ti bench effects``: cost per step of each effect.

All effects, one dropped at a time, only gravity, none (paper scene, N = 400 and 4000,
active state). An effect left out of a scene is not compiled into its kernels.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .common import (
    Options,
    evolved_block,
    init,
    paper_scene,
    print_table,
    pyplot,
    save_ms_bars,
    steps_for,
    tile,
    time_advance,
    write_csv,
)

EFFECTS_COLUMNS = ["n", "config", "effects", "mode", "steps", "ms_per_step", "saving_vs_all_ms", "fraction_of_all", "threads"]


def effect_configs(quick: bool) -> list[tuple[str, list[str]]]:
    from ..physics.effects import NAMES, PAPER_EFFECTS  # (imports Taichi: lazily)

    allx = list(PAPER_EFFECTS)
    beyond = [n for n in NAMES if n not in PAPER_EFFECTS]
    if quick:
        return [("all", allx), ("no collisions", [e for e in allx if e != "collisions"]), ("none", [])]
    return (
        [("all", allx)]
        + [(f"no {e}", [x for x in allx if x != e]) for e in allx]
        + [(f"all + {e}", [*allx, e]) for e in beyond]
        + [("only gravity", ["gravity"]), ("none", [])]
    )


def run(out: Path, o: Options) -> int:
    from ..model import Model

    sizes = tuple(o.sizes or ((40,) if o.quick else (400, 4000)))
    threads = init(o.threads)
    pre = o.pre_time if o.pre_time is not None else (3.0 if o.quick else 200.0)
    block = min(o.block, min(sizes))
    repeats = 2 if o.quick else o.repeats
    print(f"effects: evolving a {block}-iceberg shelf for {pre:g} time units (the active state) ...", flush=True)
    block_state, block_model = evolved_block(block, pre)
    rows = []
    for n in sizes:
        state = tile(block_state, n)
        steps = steps_for(n, o.quick, o.steps)
        warm = 5 if o.quick else max(10, steps // 10)
        for label, eff in effect_configs(o.quick):
            sc = paper_scene(n, extra=[("scene.effects", eff)])
            if label == "all" and n == block:
                model = block_model
            else:
                model = Model(sc, mode="auto")
            model.set_state(state)
            model.advance(warm)
            s_step = time_advance(model, steps, repeats)
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
    _plot(rows, out / "effects.png")
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


def _plot(rows: list[dict], path: Path) -> None:
    plt = pyplot()
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
    save_ms_bars(plt, fig, ax, rows, "cost of each effect (paper scene; an effect left out is not compiled)", path)

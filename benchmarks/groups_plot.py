"""The sequential passes with and without groups, from one ``profile_stages.py --groups ... --csv`` file.

    python benchmarks/groups_plot.py benchmarks/results/groups/groups_n100000.csv \\
        --out benchmarks/results/groups/groups_n100000.png

One bar per run of the profile (in the order it ran, so that a run of one group and one of
two sit side by side): the milliseconds per step of the kernels that replace the
sequential impulse pass and correction sweeps (the split, the groups' passes, the booking).
The first pair carries the kernels' first launches (loading them, first candidate lists).
"""

from __future__ import annotations

import argparse
import csv

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

PASSES = {
    "islands.split": "split",
    "impulses.impulse_pass": "impulse pass",
    "impulses.impulse_groups": "impulse pass",
    "impulses.book_later": "booking",
    "correction.sweeps_eager": "correction sweeps",
    "correction.correct_groups": "correction sweeps",
}


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("csv")
    p.add_argument("--out", required=True)
    a = p.parse_args()
    with open(a.csv) as f:
        rows = list(csv.DictReader(f))
    runs: list[tuple[str, dict[str, float]]] = []
    for r in rows:  # a new run starts at its first kernel
        if r["kernel"].startswith("forces."):
            runs.append((f"{r['groups']} group{'s' if r['groups'] != '1' else ''}", {}))
        what = PASSES.get(r["kernel"])
        if what:
            runs[-1][1][what] = runs[-1][1].get(what, 0.0) + float(r["ms_per_step"])
    fig, ax = plt.subplots(figsize=(8, 4.5))
    colors = {"split": "tab:gray", "impulse pass": "tab:red", "booking": "tab:orange", "correction sweeps": "tab:purple"}
    for k, (_label, parts) in enumerate(runs):
        bottom = 0.0
        for what, color in colors.items():
            v = parts.get(what, 0.0)
            seen = what in ax.get_legend_handles_labels()[1]
            ax.bar(k, v, bottom=bottom, color=color, label=None if seen or v == 0 else what)
            bottom += v
        ax.text(k, bottom, f"{bottom:.1f}", ha="center", va="bottom", fontsize=8)
    ax.set_xticks(range(len(runs)), [f"run {k + 1}\n{label}" for k, (label, _) in enumerate(runs)], fontsize=8)
    ax.set_ylabel("ms per step")
    n = rows[0]["n"]
    ax.set_title(
        f"N = {int(n):,}: the sequential passes, one group vs two (2-core CPU, islands off; run 1-2: first launches)",
        fontsize=9,
    )
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(a.out, dpi=120)


if __name__ == "__main__":
    main()

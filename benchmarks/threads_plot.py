"""Per-kernel ms/step on 1 and 2 threads, from ``profile_stages.py`` outputs, as CSV + PNG.

    for t in 2 1; do python benchmarks/profile_stages.py --n 100000 --warm 3000 --islands off --parts \\
        --threads $t > benchmarks/results/threads/profile_threads_${t}_COMMIT.txt; done
    python benchmarks/threads_plot.py benchmarks/results/threads

Reads every ``profile_threads_{T}_{COMMIT}.txt`` in the folder (the indented per-kernel
lines), writes ``threads.csv`` (commit, threads, kernel, ms_per_step) and ``threads.png``
(one panel per commit: each kernel's ms/step on each thread count).
"""

from __future__ import annotations

import csv
import re
import sys
from pathlib import Path


def main() -> None:
    folder = Path(sys.argv[1])
    rows = []
    for path in sorted(folder.glob("profile_threads_*_*.txt")):
        threads, commit = re.fullmatch(r"profile_threads_(\d+)_(\w+)\.txt", path.name).groups()
        for line in path.read_text().splitlines():
            m = re.fullmatch(r"\s+(\S+)\s+([\d.]+) ms/step", line)
            if m:
                rows.append({"commit": commit, "threads": int(threads), "kernel": m[1], "ms_per_step": float(m[2])})
    with open(folder / "threads.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    commits = sorted({r["commit"] for r in rows})
    fig, axes = plt.subplots(1, len(commits), figsize=(7 * len(commits), 5), squeeze=False)
    for ax, commit in zip(axes[0], commits, strict=True):
        mine = [r for r in rows if r["commit"] == commit]
        kernels = list(dict.fromkeys(r["kernel"] for r in mine))
        counts = sorted({r["threads"] for r in mine})
        width = 0.8 / len(counts)
        for k, t in enumerate(counts):
            ms = {r["kernel"]: r["ms_per_step"] for r in mine if r["threads"] == t}
            ys = [q + k * width for q in range(len(kernels))]
            ax.barh(ys, [ms.get(n, 0.0) for n in kernels], width, label=f"{t} thread(s)")
        ax.set_yticks([q + 0.4 - width / 2 for q in range(len(kernels))], kernels)
        ax.invert_yaxis()
        ax.set_xlabel("ms per step")
        ax.set_title(f"parallel form, per kernel ({commit})")
        ax.legend()
    fig.tight_layout()
    fig.savefig(folder / "threads.png", dpi=110)


if __name__ == "__main__":
    main()

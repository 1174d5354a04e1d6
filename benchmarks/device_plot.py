"""Each kernel's share of a device step, from ``profile_stages.py --csv`` files (one per N).

    python benchmarks/device_plot.py benchmarks/results/device/lavapipe_n10000.csv \\
        benchmarks/results/device/lavapipe_n100000.csv --out benchmarks/results/device/lavapipe.png

Bars in the order the step runs the kernels; the parts that run on one device thread
(a walk over one value per block of 256 bodies) in red. Software-device figures
(lavapipe): where the device path spends a step, not how fast a GPU is.
"""

from __future__ import annotations

import argparse
import csv

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("csv", nargs="+")
    p.add_argument("--out", required=True)
    a = p.parse_args()
    fig, axes = plt.subplots(1, len(a.csv), figsize=(6 * len(a.csv), 7), squeeze=False)
    for ax, path in zip(axes[0], a.csv, strict=True):
        with open(path) as f:
            rows = list(csv.DictReader(f))
        names = [r["kernel"] for r in rows]
        share = [100 * float(r["share"]) for r in rows]
        colour = ["tab:red" if r["one_thread"] == "1" else "tab:blue" for r in rows]
        ax.barh(range(len(rows)), share, color=colour)
        ax.set_yticks(range(len(rows)), names, fontsize=7)
        ax.invert_yaxis()
        total = sum(float(r["ms_per_step"]) for r in rows)
        one = sum(float(r["share"]) for r in rows if r["one_thread"] == "1")
        ax.set_xlabel("share of the step (%)")
        ax.set_title(
            f"{rows[0]['backend']}, N = {int(rows[0]['n']):,}: {total:.0f} ms/step\n"
            f"parts on one thread (red): {100 * one:.1f}% of the step",
            fontsize=9,
        )
    fig.suptitle("Device step by kernel on lavapipe (a software Vulkan device: not GPU speed)", fontsize=10)
    fig.tight_layout()
    fig.savefig(a.out, dpi=110)


if __name__ == "__main__":
    main()

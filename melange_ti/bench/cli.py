"""Entry points of the benchmarks: ``main`` (for ``melange-ti bench``) and the parser of
``python -m melange_ti.bench`` with its finer options."""

from __future__ import annotations

import argparse
import importlib
import sys
import time
from pathlib import Path

from .common import Options

WHICH = ("scaling", "accuracy", "effects", "peers")


def main(args) -> int:
    """Run benchmark ``args.which`` (a module of this package); returns the exit status."""
    which = args.which
    if which not in WHICH:
        print(f"melange-ti: error: bench {which!r}: must be one of {', '.join(WHICH)}", file=sys.stderr)
        return 2
    out = Path(getattr(args, "out", None) or "benchmarks/results")
    # its results: WHICH.csv, WHICH.png and WHICH_*.csv/png (logs are the caller's)
    existing = sorted(p.name for p in out.glob(f"{which}*") if p.suffix in (".csv", ".png")) if out.is_dir() else []
    if existing and not getattr(args, "overwrite", False):
        print(
            f"melange-ti: error: bench {which}: --out {out} already holds {', '.join(existing)} "
            "(use --overwrite to replace them, or another --out)",
            file=sys.stderr,
        )
        return 2
    out.mkdir(parents=True, exist_ok=True)
    opts = Options.from_args(args)
    t0 = time.perf_counter()
    status = importlib.import_module(f".{which}", __package__).run(out, opts)
    print(f"bench {which}: {time.perf_counter() - t0:.0f} s; results in {out / (which + '.csv')} and {out / (which + '.png')}")
    return status


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m melange_ti.bench", description="melange_ti benchmarks with finer options.")
    p.add_argument("which", choices=WHICH)
    p.add_argument("--out", default="benchmarks/results")
    p.add_argument("--quick", action="store_true", help="a tiny smoke run")
    p.add_argument("--overwrite", action="store_true", help="replace results already in --out")
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
